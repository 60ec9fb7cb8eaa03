//! The sensor's shutter end to end: camera samples taken at times drawn
//! while it is open reach `timed_sunsky` (the zenith a radiancemeter sees,
//! averaged over a year, equals Mitsuba's own average), a closed shutter
//! shows the opening time, an open shutter changes nothing in a scene that
//! nothing in changes with time, and a shutter that closes before it
//! opens is refused at its line.

mod common;

use common::{mean_and_error, render_images_from};
use std::path::Path;
use yubin_scene::load_scene_str;

/// A radiancemeter looking at the zenith of `timed_sunsky` (Tokyo's
/// defaults, turbidity 4, albedo 0.2, no sun) with the shutter open from 0
/// to `close`, path traced.
fn zenith_scene(close: f32) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="radiancemeter">
        <point name="origin" value="0, 0, 0"/>
        <vector name="direction" value="0, 0, 1"/>
        <float name="shutter_open" value="0"/>
        <float name="shutter_close" value="{close}"/>
        <film type="hdrfilm">
            <integer name="width" value="1"/>
            <integer name="height" value="1"/>
        </film>
    </sensor>
    <emitter type="timed_sunsky">
        <float name="turbidity" value="4"/>
        <float name="albedo" value="0.2"/>
        <float name="sun_scale" value="0"/>
    </emitter>
</scene>"#
    )
}

/// Over a shutter open from 0 to 1 the zenith reads the year's mean
/// (Mitsuba 3.9.1's `eval` averaged over 20 000 times: its own renders
/// see the sky at time 0 on rays that leave the scene), within four
/// standard errors of 16 renders; the mean at time 0 is rejected.
#[test]
fn open_shutter_averages_the_sky_over_the_year() {
    let images = render_images_from(&zenith_scene(1.0), 1024, 16, 0);
    let mitsubas_mean = [0.027_071_937, 0.039_532_375, 0.066_004_551];
    let at_time_zero = [0.004_218_542, 0.005_612_738, 0.006_346_605];
    for c in 0..3 {
        let values: Vec<f64> = images.iter().map(|im| f64::from(im[c])).collect();
        let (mean, error) = mean_and_error(&values);
        assert!(
            (mean - mitsubas_mean[c]).abs() < 4.0 * error,
            "channel {c}: {mean} ± {error}, Mitsuba's mean {}",
            mitsubas_mean[c]
        );
        assert!((mean - at_time_zero[c]).abs() > 10.0 * error);
    }
}

/// A shutter that never opens shows the first day at the window's start
/// (Mitsuba's `eval` at time 0), with no noise from time.
#[test]
fn closed_shutter_shows_the_opening_time() {
    let images = render_images_from(&zenith_scene(0.0), 16, 2, 0);
    let at_time_zero = [0.004_218_542f32, 0.005_612_738, 0.006_346_605];
    for image in &images {
        for c in 0..3 {
            assert!(
                (image[c] - at_time_zero[c]).abs() < 5e-4 * at_time_zero[c],
                "{image:?}"
            );
        }
    }
}

/// A scene without emitters that change with time: opening the shutter
/// draws no times, and the image is bit for bit the same.
#[test]
fn open_shutter_changes_nothing_that_does_not_change_with_time() {
    let scene = |close: &str| {
        format!(
            r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="shutter_close" value="{close}"/>
        <film type="hdrfilm">
            <integer name="width" value="8"/>
            <integer name="height" value="6"/>
        </film>
    </sensor>
    <emitter type="sunsky"/>
    <shape type="sphere">
        <point name="center" value="0, 0, 4"/>
    </shape>
</scene>"#
        )
    };
    let closed = render_images_from(&scene("0"), 4, 1, 3);
    let open = render_images_from(&scene("1"), 4, 1, 3);
    assert_eq!(closed, open);
}

#[test]
fn shutter_closing_before_it_opens_is_refused_at_its_line() {
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="shutter_open" value="1"/>
        <float name="shutter_close" value="0.5"/>
    </sensor>
</scene>"#;
    let e = match load_scene_str(xml, Path::new("shutter.xml"), &[]) {
        Ok(_) => panic!("a shutter closing before it opens was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("shutter.xml:4") && e.contains("closes (0.5) before it opens (1)"),
        "{e}"
    );
}
