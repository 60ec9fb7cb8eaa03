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
    // A developer's own $OCIO would change what PNGs show.
    let out = Command::new(env!("CARGO_BIN_EXE_yubin"))
        .env_remove("OCIO")
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

/// Blender's config.ocio from `scripts/ocio-ref setup`, or why there is none.
fn blender_config() -> Result<PathBuf, String> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/ocio-ref");
    let out = Command::new(&script)
        .arg("config")
        .output()
        .map_err(|e| format!("cannot run scripts/ocio-ref: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "no OCIO reference (run scripts/ocio-ref setup): {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(PathBuf::from(String::from_utf8_lossy(&out.stdout).trim()))
}

/// yubin's PNGs through Blender's config (written by `render --ocio` and by
/// `tonemap` from the EXR) against OpenColorIO applying the same config to
/// the same EXR: within 1/255 per channel on at least 99.9 % of pixels,
/// for Filmic with its base look and two others, AgX and False Color.
#[test]
fn ocio_views_match_opencolorio_on_a_render() {
    let config = match blender_config() {
        Ok(c) => c,
        Err(why) => {
            eprintln!("skipping: {why}");
            return;
        }
    };
    let config = config.to_str().unwrap();
    let d = std::env::temp_dir().join(format!("yubin-display-ocio-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    // The light in the frame gives the views highlights to roll off.
    let (code, stderr) = yubin(&d, &["-o", "render.exr"]);
    assert_eq!(code, Some(0), "{stderr}");
    let exr = read_image(&d.join("render.exr"), ColorHandling::Raw).unwrap();
    let rgb: Vec<f32> = exr
        .data
        .chunks_exact(exr.channels)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let bytes: Vec<u8> = rgb.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(d.join("render.f32"), bytes).unwrap();
    let (w, h) = (exr.width.to_string(), exr.height.to_string());
    for (view, look) in [
        ("Filmic", "Medium Contrast"),
        ("Filmic", "High Contrast"),
        ("Filmic", "Low Contrast"),
        ("AgX", ""),
        ("False Color", ""),
    ] {
        let status =
            Command::new(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/ocio-ref"))
                .args(["apply", config, "sRGB", view, look])
                .arg(d.join("render.f32"))
                .arg(d.join("reference.u8"))
                .args([&w, &h])
                .status()
                .unwrap();
        assert!(status.success());
        let expected = std::fs::read(d.join("reference.u8")).unwrap();
        let mut view_args = vec!["--ocio", config, "--view", view];
        if !look.is_empty() {
            view_args.extend(["--look", look]);
        }
        let mut render_args = view_args.clone();
        render_args.extend(["-o", "render.png"]);
        let (code, stderr) = yubin(&d, &render_args);
        assert_eq!(code, Some(0), "{stderr}");
        let out = Command::new(env!("CARGO_BIN_EXE_yubin"))
            .env_remove("OCIO")
            .current_dir(&d)
            .args(["tonemap", "render.exr", "-o", "tonemap.png"])
            .args(&view_args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        for png in ["render.png", "tonemap.png"] {
            let ours: Vec<u8> = pixels(&d.join(png))
                .iter()
                .map(|v| (v * 255.0).round() as u8)
                .collect();
            assert_eq!(ours.len(), expected.len());
            let far = ours
                .chunks_exact(3)
                .zip(expected.chunks_exact(3))
                .filter(|(a, b)| (0..3).any(|c| a[c].abs_diff(b[c]) > 1))
                .count();
            let share = far as f64 / (ours.len() / 3) as f64;
            eprintln!("{png} {view} {look}: {far} pixels off by more than 1/255");
            assert!(
                share <= 0.001,
                "{png} {view} {look}: {:.3} % off",
                100.0 * share
            );
        }
    }
    std::fs::remove_dir_all(&d).ok();
}
