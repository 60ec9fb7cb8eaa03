//! Per-pixel Z-tests of small scenes (`scenes/parity/*.xml`, 32×32 to 96×48) against
//! Mitsuba 3 references committed in `tests/refs/` (mean and per-sample
//! variance, made by `scripts/mitsuba-ref reference`; the commands are in
//! `scripts/README.md`). The method is Mitsuba's `test_renders.py`, as in
//! `mitsuba_ztest_shared.rs`: the yubin render uses ⌊2·10⁶ / pixels⌋ spp,
//! seed 0, and is compared in XYZ with Šidák-corrected significance 0.01.
//! Needs nothing outside the repository.

mod common;

use common::render_file;
use std::path::Path;
use yubin_core::testing::ztest::z_test;
use yubin_scene::image_io::{read_image, ColorHandling, Image};

fn rgb(img: &Image) -> Vec<f32> {
    img.data
        .chunks_exact(img.channels)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect()
}

/// Z-tests yubin's render of `scenes/parity/{name}.xml` against the
/// committed reference `tests/refs/{name}_{mean,var}.exr`.
fn parity(name: &str) {
    parity_with(name, 1);
}

/// [`parity`] with `factor` times the samples per pixel, for a scene whose
/// variance per sample is too high for the usual count to tell a 3 % bias.
fn parity_with(name: &str, factor: u32) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join(format!("../../scenes/parity/{name}.xml"));
    let refs = root.join("tests/refs");
    let read = |suffix: &str| {
        let path = refs.join(format!("{name}_{suffix}.exr"));
        read_image(&path, ColorHandling::Raw).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    };
    let (ref_mean, ref_var) = (read("mean"), read("var"));
    let pixels = ref_mean.width * ref_mean.height;
    let spp = (2_000_000 / pixels) as u32 * factor;
    let out = render_file(&scene, &[], spp, 0);
    let mean = out.image.select_channels(0..3);
    assert_eq!(
        (mean.width as usize, mean.height as usize),
        (ref_mean.width, ref_mean.height),
        "{name}: image size differs from the reference"
    );
    let (reference, variance) = (rgb(&ref_mean), rgb(&ref_var));
    let report = z_test(&mean.data, spp, &reference, &variance, 0.01);
    println!("{name}: {report:?}");
    assert!(report.passed, "{name}: Z-test failed: {report:?}");
    // The test must be able to fail: a 3 % brighter image is rejected.
    let brighter: Vec<f32> = mean.data.iter().map(|v| v * 1.03).collect();
    let report = z_test(&brighter, spp, &reference, &variance, 0.01);
    assert!(
        !report.passed,
        "{name}: the Z-test cannot tell a 3 % bias: {report:?}"
    );
}

/// Checkerboard texture, `twosided` diffuse, sphere, rectangle area light,
/// point light, path tracing (4 bounces), gaussian filter.
#[test]
fn parity_checker_area() {
    parity("checker_area");
}

/// Bitmap (sRGB PNG) texture, disk, envmap and directional light, path
/// tracing (3 bounces), box filter.
#[test]
fn parity_envmap_bitmap() {
    parity("envmap_bitmap");
}

/// Every `principled` and `principledthin` parameter, constant and
/// textured, on 18 spheres under a constant environment and an area light
/// (8 bounces, box filter). Its float checkerboards are read with
/// Mitsuba 3.9.1's `eval_1` colour swap in both renderers.
#[test]
fn parity_principled() {
    parity("principled");
}

/// The `depth` integrator: a sphere, a cube and a floor, a near clip of
/// 0.5 (depth counts from it, as Mitsuba's `si.t`), misses at the top.
#[test]
fn parity_depth() {
    parity("depth");
}

/// The `batch` sensor: a perspective and an orthographic sensor side by
/// side (each as alone on a 32×32 film), the default gaussian filter
/// spreading samples across the seam.
#[test]
fn parity_batch() {
    parity("batch");
}

/// Phase functions under multiple scattering: `sggx` matrices varying over
/// a grid in a heterogeneous sphere, `tabphase` in a chromatic cube,
/// `blendphase` of hg and tabphase; sky and sun.
#[test]
fn parity_phases() {
    parity("phases");
}

/// Gaussian splats as surfaces: `ellipsoids` and `ellipsoidsmesh` shells
/// (rotated, non-uniformly scaled `to_world`, adaptive extents), and a
/// `dielectric` Gaussian whose refracted rays leave without a hit.
#[test]
fn parity_ellipsoids() {
    parity("ellipsoids");
}

/// The `measured` BSDF: tabulated GGX files (isotropic; anisotropic folded
/// by a half-turn and by mirrors) on spheres under sky, sun and an area
/// light.
#[test]
fn parity_measured() {
    parity("measured");
}

/// The `sunsky` emitter by date, time and place, in a y-up frame: the sky
/// seen directly, diffuse and rough metal under sun and sky.
#[test]
fn parity_sunsky() {
    parity("sunsky");
}

/// `timed_sunsky` over half a year of days from 8:00 to 16:30, the
/// sensor's shutter open: the sun's smeared shadows, by light sampling
/// alone (where Mitsuba 3.9.1 reads the time right). The moving sun makes
/// each sample noisy: four times the samples.
#[test]
fn parity_timed_sunsky() {
    parity_with("timed_sunsky", 4);
}

/// `linearcurve`: a tapering helix, a zigzag and a cone-like stub (round
/// joints and capped ends) with a checkerboard over their uv.
#[test]
fn parity_linearcurve() {
    parity("linearcurve");
}

/// `bsplinecurve`: a tapering helix and a wave of growing radius, open
/// ends, a checkerboard over their uv.
#[test]
fn parity_bsplinecurve() {
    parity("bsplinecurve");
}

/// The `hair` BSDF on `bsplinecurve` strands over a sphere: blonde hair,
/// long paths through many fibres.
#[test]
fn parity_hair() {
    parity("hair");
}
