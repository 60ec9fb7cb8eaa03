//! Helpers shared by the render tests (each test binary uses some of them).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use yubin_core::render::{render, RenderOutput, RenderSettings};
use yubin_scene::load_scene;

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
