//! PNG output through `--exposure` and `--tonemap`: exposure brightens by
//! stops, `filmic` rolls highlights off instead of clipping them, EXR
//! output stays scene-linear, and an unknown curve is a usage error that
//! lists the known ones.

use std::path::{Path, PathBuf};
use std::process::Command;
use yubin_scene::image_io::{read_image, ColorHandling};

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-display-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Renders the built-in Cornell box (64 × 64, 4 spp) with `args`.
fn yubin(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(dir)
        .args([
            "render", "--spp", "4", "-D", "resx=64", "-D", "resy=64", "--quiet",
        ])
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn pixels(path: &Path) -> Vec<f32> {
    read_image(path, ColorHandling::Raw).unwrap().data
}

#[test]
fn exposure_and_tone_curves_shape_png_output() {
    let d = dir();
    for (name, args) in [
        ("plain.png", vec![]),
        ("bright.png", vec!["--exposure", "1"]),
        ("filmic.png", vec!["--tonemap", "filmic"]),
        ("plain.exr", vec![]),
        ("bright.exr", vec!["--exposure", "2"]),
    ] {
        let mut all = args.clone();
        all.extend(["-o", name]);
        let (code, stderr) = yubin(&d, &all);
        assert_eq!(code, Some(0), "{name}: {stderr}");
    }
    let (plain, bright, filmic) = (
        pixels(&d.join("plain.png")),
        pixels(&d.join("bright.png")),
        pixels(&d.join("filmic.png")),
    );
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    assert!(
        mean(&bright) > mean(&plain) * 1.2,
        "{} vs {}",
        mean(&bright),
        mean(&plain)
    );
    // The light clips to white under srgb; filmic keeps it below white
    // and darkens the mid-tones (its toe and shoulder).
    let max = |v: &[f32]| v.iter().copied().fold(0.0f32, f32::max);
    assert_eq!(max(&plain), 1.0);
    assert!(
        mean(&filmic) < mean(&plain),
        "{} vs {}",
        mean(&filmic),
        mean(&plain)
    );
    assert_eq!(pixels(&d.join("plain.exr")), pixels(&d.join("bright.exr")));
    let (code, stderr) = yubin(&d, &["--tonemap", "aces", "-o", "x.png"]);
    assert_eq!(code, Some(2));
    assert!(
        stderr.contains("srgb") && stderr.contains("filmic"),
        "{stderr}"
    );
    assert!(!d.join("x.png").exists());
    std::fs::remove_dir_all(&d).ok();
}
