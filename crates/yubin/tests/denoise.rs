//! `--denoise` (built with `--features denoise`, Open Image Denoise from
//! `scripts/oidn-setup`): the denoised Cornell box at 4 spp is far closer
//! to a 256-spp render than the noisy one, and its guide layers are in
//! the EXR. Without the feature, `--denoise` is refused before rendering.

use std::path::{Path, PathBuf};
use std::process::Command;

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-denoise-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn yubin(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(dir)
        .args(["render", "-D", "resx=128", "-D", "resy=128", "--quiet"])
        .args(args)
        .output()
        .unwrap()
}

#[cfg(feature = "denoise")]
#[test]
fn denoising_brings_a_4_spp_render_close_to_a_256_spp_one() {
    use yubin_scene::image_io::{read_image, ColorHandling};
    let d = dir();
    for (name, args) in [
        ("reference.exr", vec!["--spp", "256", "-D", "rfilter=box"]),
        ("noisy.exr", vec!["--spp", "4", "-D", "rfilter=box"]),
        ("denoised.exr", vec!["--spp", "4", "--denoise"]),
    ] {
        let mut all = args;
        all.extend(["-o", name]);
        let out = yubin(&d, &all);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let rgb = |name: &str| {
        let img = read_image(&d.join(name), ColorHandling::Raw).unwrap();
        img.data
            .chunks_exact(img.channels)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect::<Vec<f32>>()
    };
    let reference = rgb("reference.exr");
    let rel_mse = |x: &[f32]| {
        x.iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).powi(2) / (b * b + 0.01))
            .sum::<f32>()
            / x.len() as f32
    };
    let noisy = rgb("noisy.exr");
    let denoised = rgb("denoised.exr");
    let (e_noisy, e_denoised) = (rel_mse(&noisy), rel_mse(&denoised));
    eprintln!("relMSE noisy {e_noisy:.5}, denoised {e_denoised:.5}");
    assert!(
        e_denoised * 10.0 < e_noisy,
        "noisy {e_noisy}, denoised {e_denoised}"
    );
    // The guides the denoiser used are in the EXR.
    let image = exr::prelude::read_all_flat_layers_from_file(d.join("denoised.exr")).unwrap();
    let names: Vec<String> = image.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    for name in ["albedo.R", "normal.X", "R"] {
        assert!(
            names.iter().any(|n| n == name),
            "{name} missing from {names:?}"
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

#[cfg(not(feature = "denoise"))]
#[test]
fn denoise_without_the_feature_is_refused_before_rendering() {
    let d = dir();
    let out = yubin(&d, &["--spp", "1", "--denoise", "-o", "x.exr"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--features denoise"), "{stderr}");
    assert!(!d.join("x.exr").exists());
    std::fs::remove_dir_all(&d).ok();
}
