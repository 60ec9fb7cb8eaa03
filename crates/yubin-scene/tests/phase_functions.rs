//! Phase functions in a whole render, against single scattering computed
//! here: a `radiancemeter` looks along +x through a unit cube of
//! scattering medium (σt = 1, albedo 1) lit by a directional light, so
//! that with `volpath` at `max_depth` 2 the radiance is
//! ∫ e^−(s+1) p(θ) e^−d(s) ds over the ray's 2 units in the cube, d the
//! distance to the cube's side toward the light, θ the fixed scattering
//! angle (the scenes Mitsuba 3.9.1 renders to the same values:
//! `tabphase` 0.026802 ± 0.000026 for 0.026790 computed). The meter's film
//! is 1 × 16 pixels: 16 independent estimates give the standard error.

mod common;

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::load_scene_str;

/// The light travels along (0.6, 0, −0.8); the meter sees light leaving
/// along −x: cos θ = −0.6.
fn scene(phase: &str, film: (u32, u32)) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="volpath"><integer name="max_depth" value="2"/></integrator>
<sensor type="radiancemeter">
  <point name="origin" value="-5, 0, 0"/>
  <vector name="direction" value="1, 0, 0"/>
  <film type="hdrfilm"><integer name="width" value="{}"/><integer name="height" value="{}"/>
    <rfilter type="box"/></film>
</sensor>
<emitter type="directional">
  <vector name="direction" value="0.6, 0, -0.8"/>
  <rgb name="irradiance" value="1, 1, 1"/>
</emitter>
<shape type="cube">
  <bsdf type="null"/>
  <medium type="homogeneous" name="interior">
    <float name="sigma_t" value="1"/>
    <float name="albedo" value="1"/>
    {phase}
  </medium>
</shape>
</scene>"#,
        film.0, film.1
    )
}

/// ∫ e^−(s+1) e^−d(s) ds over s ∈ [−1, 1], d(s) = min(1.25, (s + 1)/0.6).
fn path_integral() -> f64 {
    let n = 100_000;
    (0..n)
        .map(|i| {
            let s = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
            (-(s + 1.0)).exp() * (-(1.25f64).min((s + 1.0) / 0.6)).exp() * 2.0 / n as f64
        })
        .sum()
}

/// The z-score of the meter's reading for `phase` against p(θ) = `p`.
fn z_score(phase: &str, p: f64) -> f64 {
    let loaded = load_scene_str(&scene(phase, (1, 16)), Path::new("meter.xml"), &[])
        .unwrap_or_else(|e| panic!("{e}"));
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings {
            spp: 16_384,
            seed: 7,
        },
        &|_| {},
    );
    let (mean, se) = common::pixel_mean_and_error(&out.image.data, 0);
    let expected = path_integral() * p;
    (mean - expected) / se
}

const TAU: f64 = 2.0 * std::f64::consts::PI;

#[test]
fn tabphase_and_blendphase_scatter_as_computed() {
    // "1, 3, 2" at cos θ = −0.6: 1.8, over its integral 4.5, over 2π.
    let tab = 1.8 / 4.5 / TAU;
    let tabphase = r#"<phase type="tabphase"><string name="values" value="1, 3, 2"/></phase>"#;
    let z = z_score(tabphase, tab);
    assert!(z.abs() < 4.0, "tabphase: z = {z}");
    // Read the other way round (forward first), the same table is wrong.
    let z = z_score(tabphase, (1.0 + 0.4 * 1.0) / 4.5 / TAU);
    assert!(
        z.abs() > 6.0,
        "tabphase the wrong way round passes: z = {z}"
    );
    // A quarter of the second (the table), three quarters isotropic.
    let iso = 1.0 / (2.0 * TAU);
    let blend = r#"<phase type="blendphase"><float name="weight" value="0.25"/>
        <phase type="isotropic"/>
        <phase type="tabphase"><string name="values" value="1, 3, 2"/></phase></phase>"#;
    let z = z_score(blend, 0.75 * iso + 0.25 * tab);
    assert!(z.abs() < 4.0, "blendphase: z = {z}");
    let z = z_score(blend, 0.25 * iso + 0.75 * tab);
    assert!(
        z.abs() > 6.0,
        "blendphase with its parts swapped passes: z = {z}"
    );
    // Henyey–Greenstein through the same test, g = 0.5.
    let g: f64 = 0.5;
    let hg = (1.0 - g * g) / (2.0 * TAU * (1.0 + g * g - 2.0 * g * -0.6).powf(1.5));
    let z = z_score(
        r#"<phase type="hg"><float name="g" value="0.5"/></phase>"#,
        hg,
    );
    assert!(z.abs() < 4.0, "hg: z = {z}");
}

#[test]
fn bad_phase_tables_and_meters_are_refused_at_their_line() {
    let error = |phase: &str, film: (u32, u32)| match load_scene_str(
        &scene(phase, film),
        Path::new("bad.xml"),
        &[],
    ) {
        Ok(_) => panic!("{phase} loaded"),
        Err(e) => e.to_string(),
    };
    let one = error(
        r#"<phase type="tabphase"><string name="values" value="1"/></phase>"#,
        (1, 1),
    );
    assert!(
        one.contains("bad.xml:18") && one.contains("at least two"),
        "{one}"
    );
    let neg = error(
        r#"<phase type="tabphase"><string name="values" value="1, -2"/></phase>"#,
        (1, 1),
    );
    assert!(neg.contains("must not be negative"), "{neg}");
    let three = error(
        r#"<phase type="blendphase"><phase type="isotropic"/></phase>"#,
        (1, 1),
    );
    assert!(
        three.contains("exactly two nested phase functions, not 1"),
        "{three}"
    );
    let film = error(r#"<phase type="isotropic"/>"#, (2, 2));
    assert!(
        film.contains("bad.xml:3") && film.contains("must be 1 pixel wide or tall, not 2x2"),
        "{film}"
    );
}
