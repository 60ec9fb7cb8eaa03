//! Helpers shared by the render tests (each test binary uses some of them).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use yubin_core::render::{render, RenderOutput, RenderSettings};
use yubin_scene::{load_scene, load_scene_str};

/// `/work/shared` (or `$YUBIN_SHARED`), when present.
pub fn shared_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("YUBIN_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared"));
    dir.is_dir().then_some(dir)
}

/// The shared directory, or `None` after printing why the test skips.
pub fn shared_or_skip(test: &str) -> Option<PathBuf> {
    let dir = shared_dir();
    if dir.is_none() {
        println!("skipping {test}: ../shared (Mitsuba test data and assets) is not present; set YUBIN_SHARED to its path");
    }
    dir
}

/// Loads and renders a scene file at `spp` with `seed`.
pub fn render_file(path: &Path, defines: &[(String, String)], spp: u32, seed: u32) -> RenderOutput {
    let loaded = load_scene(path, defines).unwrap_or_else(|e| panic!("{e}"));
    render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp, seed },
        &|_| {},
    )
}

/// Per pixel-channel mean and sample variance of `k` renders (seeds
/// 0..k) of the scene `xml`.
pub fn render_statistics(xml: &str, spp: u32, k: u32) -> (Vec<f64>, Vec<f64>) {
    render_statistics_from(xml, spp, k, 0)
}

/// [`render_statistics`] with seeds `seed0..seed0 + k` (two scenes
/// compared with different seeds give independent estimates).
pub fn render_statistics_from(xml: &str, spp: u32, k: u32, seed0: u32) -> (Vec<f64>, Vec<f64>) {
    statistics(&render_images_from(xml, spp, k, seed0))
}

/// The images of `k` renders (seeds `seed0..seed0 + k`) of the scene
/// `xml`.
pub fn render_images_from(xml: &str, spp: u32, k: u32, seed0: u32) -> Vec<Vec<f32>> {
    let loaded = load_scene_str(xml, Path::new("test.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    (0..k)
        .map(|i| {
            render(
                &loaded.scene,
                loaded.integrator.as_ref(),
                &RenderSettings {
                    spp,
                    seed: seed0 + i,
                },
                &|_| {},
            )
            .image
            .data
        })
        .collect()
}

/// Per pixel-channel mean and sample variance over `images`.
pub fn statistics(images: &[Vec<f32>]) -> (Vec<f64>, Vec<f64>) {
    let k = images.len();
    let n = images[0].len();
    let mean: Vec<f64> = (0..n)
        .map(|i| images.iter().map(|im| im[i] as f64).sum::<f64>() / k as f64)
        .collect();
    let var = (0..n)
        .map(|i| {
            images
                .iter()
                .map(|im| (im[i] as f64 - mean[i]).powi(2))
                .sum::<f64>()
                / (k - 1) as f64
        })
        .collect();
    (mean, var)
}

/// Asserts that two scenes converge to the same image, from `k` renders
/// of each at `spp`: per pixel and channel, Welch's t = (mean_a − mean_b)
/// / √(s²_a/k + s²_b/k) stays below 7 (with 15 + 15 degrees of freedom
/// at k = 16, a correct pair exceeds it with probability ~1e-7 per
/// value), and the images' sums agree within 4 standard errors. A missing
/// factor (π, a cosine, an area) moves the mean by far more.
pub fn assert_same_image(a: &str, b: &str, spp: u32, k: u32, label: &str) {
    let (ma, va) = render_statistics(a, spp, k);
    let (mb, vb) = render_statistics(b, spp, k);
    let mut worst = (0.0f64, 0usize);
    for i in 0..ma.len() {
        let se = ((va[i] + vb[i]) / k as f64).sqrt().max(1e-6);
        let t = (ma[i] - mb[i]).abs() / se;
        if t > worst.0 {
            worst = (t, i);
        }
    }
    assert!(
        worst.0 < 7.0,
        "{label}: pixel {} channel {}: {} vs {} (t = {:.1})",
        worst.1 / 3,
        worst.1 % 3,
        ma[worst.1],
        mb[worst.1],
        worst.0
    );
    let sum = |v: &[f64]| v.iter().sum::<f64>();
    let se = ((sum(&va) + sum(&vb)) / k as f64).sqrt();
    let (x, y) = (sum(&ma), sum(&mb));
    assert!(
        (x - y).abs() < 4.0 * se,
        "{label}: image sums {x} vs {y} (standard error {se})"
    );
    assert!(x > 0.0 && y > 0.0, "{label}: black images");
}

/// The mean of `values` (independent estimates) and its standard error.
pub fn mean_and_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// [`mean_and_error`] over the pixels of an RGB image's channel `c` (the
/// pixels of a meter's film are independent estimates of one value).
pub fn pixel_mean_and_error(rgb: &[f32], c: usize) -> (f64, f64) {
    let values: Vec<f64> = rgb.chunks_exact(3).map(|p| f64::from(p[c])).collect();
    mean_and_error(&values)
}

/// Writes a Mitsuba `.vol` file (version 3, float32) of `dims` voxels and
/// `channels` channels to `path` (box [0, 1]³).
pub fn write_vol(path: &Path, dims: [i32; 3], channels: i32, data: &[f32]) {
    let mut vol = b"VOL\x03".to_vec();
    for v in [1, dims[0], dims[1], dims[2], channels] {
        vol.extend(v.to_le_bytes());
    }
    for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0].iter().chain(data) {
        vol.extend(v.to_le_bytes());
    }
    std::fs::write(path, vol).unwrap();
}

/// A fresh directory under the system's temporary one, for files a test
/// writes.
pub fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("yubin-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
