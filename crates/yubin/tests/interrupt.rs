//! Ctrl-C keeps the work of a plain render (no `--checkpoint`, no
//! `--pass-spp`): SIGINT after a few seconds exits 130 with the image of
//! the samples done, whose mean is the full render's within noise, and
//! the summary says how many samples that was. A particle tracer keeps
//! its light paths the same way (SIGTERM: 143).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;
use yubin_scene::image_io::{read_image, ColorHandling};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-interrupt-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `yubin render` of the built-in Cornell box at 32 × 32 with `extra`.
fn yubin(dir: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_yubin"));
    c.current_dir(dir)
        .args(["render", "-D", "resx=32", "-D", "resy=32", "--quiet"])
        .args(extra);
    c
}

/// Starts `command`, sends `signal` after `after`; returns the exit code
/// and stderr.
fn interrupted(mut command: Command, signal: &str, after: Duration) -> (Option<i32>, String) {
    let child = command.stderr(Stdio::piped()).spawn().unwrap();
    std::thread::sleep(after);
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The number of samples per pixel an "interrupted after N of M" line
/// names.
fn samples_named(stderr: &str) -> u64 {
    let after = stderr
        .split("interrupted after ")
        .nth(1)
        .unwrap_or_else(|| panic!("no interruption line: {stderr}"));
    after.split(' ').next().unwrap().parse().unwrap()
}

/// The mean of the RGB channels of an EXR.
fn mean(path: &Path) -> f64 {
    let image = read_image(path, ColorHandling::Raw).unwrap();
    image.data.iter().map(|&v| f64::from(v)).sum::<f64>() / image.data.len() as f64
}

#[test]
fn sigint_on_a_plain_render_keeps_the_samples_done() {
    let d = dir("plain");
    let full = yubin(&d, &["--spp", "256", "-o", "full.exr"])
        .output()
        .unwrap();
    assert!(full.status.success());
    let (code, stderr) = interrupted(
        yubin(&d, &["--spp", "10000000", "-o", "cut.exr"]),
        "-INT",
        Duration::from_secs(3),
    );
    assert_eq!(code, Some(130), "{stderr}");
    let spp = samples_named(&stderr);
    assert!((1..10_000_000).contains(&spp), "{stderr}");
    assert!(stderr.contains("of 10000000 samples per pixel"), "{stderr}");
    // The Cornell box's image mean is known to well under a percent at
    // these counts; an image averaged over the wrong count is off by
    // twice or more.
    let (cut, full) = (mean(&d.join("cut.exr")), mean(&d.join("full.exr")));
    println!("{spp} spp: mean {cut:.5}, full render {full:.5}");
    assert!(
        (cut / full - 1.0).abs() < 0.02,
        "mean {cut} against {full} ({spp} spp)"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn sigterm_on_a_particle_tracer_keeps_its_light_paths() {
    let d = dir("ptracer");
    let scene = include_str!("../../../scenes/cornell-box.xml").replace(
        r#"<integrator type="path">"#,
        r#"<integrator type="ptracer">"#,
    );
    assert!(scene.contains("ptracer"));
    std::fs::write(d.join("ptracer.xml"), scene).unwrap();
    let full = yubin(&d, &["ptracer.xml", "--spp", "64", "-o", "full.exr"])
        .output()
        .unwrap();
    assert!(
        full.status.success(),
        "{}",
        String::from_utf8_lossy(&full.stderr)
    );
    let (code, stderr) = interrupted(
        yubin(&d, &["ptracer.xml", "--spp", "10000000", "-o", "cut.exr"]),
        "-TERM",
        Duration::from_secs(3),
    );
    assert_eq!(code, Some(143), "{stderr}");
    let spp = samples_named(&stderr);
    assert!(spp >= 1, "{stderr}");
    let (cut, full) = (mean(&d.join("cut.exr")), mean(&d.join("full.exr")));
    println!("{spp} paths per pixel: mean {cut:.5}, full render {full:.5}");
    assert!(
        (cut / full - 1.0).abs() < 0.02,
        "mean {cut} against {full} ({spp} paths per pixel)"
    );
    std::fs::remove_dir_all(&d).ok();
}
