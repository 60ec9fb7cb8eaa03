//! Rendering in passes from the command line: `--time-limit` stops within
//! a pass of its limit and writes the average of the passes done (an
//! unbiased image: a Z-test against a longer render),
//! `--progressive` renders in passes to the same image as one go, and
//! `--crop` renders exactly that window of the film (bad windows: exit 1,
//! nothing written).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use yubin_scene::image_io::{read_image, ColorHandling};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-passes-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `yubin render` on the built-in Cornell box (box filter, 64 × 48)
/// with `args`; returns the exit status and stderr.
fn yubin(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(dir)
        .args([
            "render",
            "-D",
            "rfilter=box",
            "-D",
            "resx=64",
            "-D",
            "resy=48",
        ])
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The number after "in" and before " passes" in a summary line.
fn passes_in(summary: &str) -> u32 {
    let before = summary.split(" passes").next().unwrap();
    before.rsplit(' ').next().unwrap().parse().unwrap()
}

#[test]
fn time_limit_stops_within_a_pass() {
    let d = dir("time");
    let t = Instant::now();
    let (code, stderr) = yubin(&d, &["--time-limit", "1", "-o", "t.exr"]);
    let wall = t.elapsed().as_secs_f64();
    assert_eq!(code, Some(0), "{stderr}");
    let passes = passes_in(&stderr);
    assert!(passes >= 2, "{stderr}");
    // A pass of 64 × 48 pixels at 1 spp takes milliseconds: the render
    // ends within the limit plus start-up, not a pass beyond it.
    assert!(wall < 2.5, "took {wall} s: {stderr}");
    let img = read_image(&d.join("t.exr"), ColorHandling::Raw).unwrap();
    assert!(img.data.iter().all(|v| v.is_finite()) && img.data.iter().any(|v| *v > 0.0));
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn progressive_passes_give_the_image_of_one_go() {
    let d = dir("progressive");
    let (code, stderr) = yubin(&d, &["--spp", "6", "-o", "one.exr"]);
    assert_eq!(code, Some(0), "{stderr}");
    let (code, stderr) = yubin(
        &d,
        &[
            "--spp",
            "6",
            "--progressive",
            "0",
            "--pass-spp",
            "2",
            "-o",
            "passes.exr",
        ],
    );
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(passes_in(&stderr), 3, "{stderr}");
    let one = read_image(&d.join("one.exr"), ColorHandling::Raw).unwrap();
    let passes = read_image(&d.join("passes.exr"), ColorHandling::Raw).unwrap();
    // The same samples, summed in another order.
    let worst = one
        .data
        .iter()
        .zip(&passes.data)
        .map(|(a, b)| (a - b).abs() / a.abs().max(1e-3))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "relative difference {worst}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn crop_renders_that_window_of_the_film() {
    let d = dir("crop");
    let (code, stderr) = yubin(&d, &["--spp", "2", "-o", "full.exr"]);
    assert_eq!(code, Some(0), "{stderr}");
    let (code, stderr) = yubin(
        &d,
        &["--spp", "2", "--crop", "10,5,20,12", "-o", "crop.exr"],
    );
    assert_eq!(code, Some(0), "{stderr}");
    let full = read_image(&d.join("full.exr"), ColorHandling::Raw).unwrap();
    let crop = read_image(&d.join("crop.exr"), ColorHandling::Raw).unwrap();
    assert_eq!((crop.width, crop.height), (20, 12));
    let c = full.channels;
    for y in 0..12 {
        for x in 0..20 {
            let a = &full.data[((y + 5) * full.width + x + 10) * c..][..3];
            let b = &crop.data[(y * crop.width + x) * crop.channels..][..3];
            assert_eq!(a, b, "pixel ({x}, {y}) of the window");
        }
    }
    for bad in ["60,0,10,10", "0,0,0,4", "1,2,3"] {
        let (code, stderr) = yubin(&d, &["--crop", bad, "-o", "bad.exr"]);
        assert!(
            code == Some(1) || code == Some(2),
            "{bad}: {code:?} {stderr}"
        );
        assert!(stderr.contains("--crop"), "{bad}: {stderr}");
        assert!(!d.join("bad.exr").exists(), "{bad}: an image was written");
    }
    std::fs::remove_dir_all(&d).ok();
}

/// A small scene under `moment` (mean and second moment per pixel).
const MOMENT_SCENE: &str = r#"<scene version="3.0.0">
<integrator type="moment"><integrator type="path"><integer name="max_depth" value="4"/></integrator></integrator>
<sensor type="perspective"><float name="fov" value="45"/>
  <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/><rfilter type="box"/></film>
</sensor>
<emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
<emitter type="point"><point name="position" value="2, 3, 2"/><rgb name="intensity" value="10"/></emitter>
<shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.4, 0.2"/></bsdf></shape>
<shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="-1"/></transform></shape>
</scene>"#;

/// The time-limited image is the mean of the samples it took: Mitsuba's
/// per-pixel Z-test against a 4096-spp render of the same scene (its
/// per-sample variance from the second moment) passes, and a 5 % brighter
/// image fails it.
#[test]
fn time_limited_image_is_unbiased() {
    use yubin_core::testing::ztest::z_test;
    let d = dir("unbiased");
    std::fs::write(d.join("m.xml"), MOMENT_SCENE).unwrap();
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_yubin"))
            .current_dir(&d)
            .args(["render", "m.xml"])
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{stderr}");
        stderr
    };
    let summary = run(&["--time-limit", "0.3", "--pass-spp", "8", "-o", "t.exr"]);
    // "t.exr: 24x16, N spp in K passes in ..."
    let spp: u32 = summary
        .split(" spp")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no spp in {summary}"));
    assert!((8..4096).contains(&spp), "{summary}");
    // The reference in this process: RGB, then the second moment.
    let loaded = yubin_scene::load_scene(&d.join("m.xml"), &[]).unwrap();
    let settings = yubin_core::render::RenderSettings { spp: 4096, seed: 7 };
    let out = yubin_core::render::render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &settings,
        &|_| {},
    );
    let channels = out.image.channels;
    let (mut mean, mut var) = (Vec::new(), Vec::new());
    for px in out.image.data.chunks_exact(channels) {
        for c in 0..3 {
            mean.push(px[c]);
            var.push((px[3 + c] - px[c] * px[c]).max(0.0));
        }
    }
    let limited = read_image(&d.join("t.exr"), ColorHandling::Raw).unwrap();
    assert_eq!(limited.channels, 3);
    let test = limited.data.clone();
    let report = z_test(&test, spp, &mean, &var, 0.01);
    assert!(report.passed, "{report:?}");
    let brighter: Vec<f32> = test.iter().map(|v| v * 1.05).collect();
    assert!(!z_test(&brighter, spp, &mean, &var, 0.01).passed);
    std::fs::remove_dir_all(&d).ok();
}

/// The summary's noise estimate (the mean relative error of the pixels'
/// means, from their even and odd samples) falls as 1/√spp: four times
/// the samples, half the noise.
#[test]
fn summary_estimates_the_noise() {
    let d = dir("noise");
    let noise = |spp: &str| -> f32 {
        let (code, stderr) = yubin(&d, &["--spp", spp, "-o", "n.exr"]);
        assert_eq!(code, Some(0), "{stderr}");
        let after = stderr
            .split("noise ~")
            .nth(1)
            .unwrap_or_else(|| panic!("{stderr}"));
        after.split(' ').next().unwrap().parse().unwrap()
    };
    let ratio = noise("16") / noise("64");
    assert!(
        (1.6..2.4).contains(&ratio),
        "16 → 64 spp divided the noise by {ratio}"
    );
    std::fs::remove_dir_all(&d).ok();
}
