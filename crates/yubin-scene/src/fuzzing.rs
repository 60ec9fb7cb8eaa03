//! Fuzz harnesses: one function per parser, each feeding arbitrary bytes
//! through the same entry point yubin itself calls.
//!
//! The targets in `fuzz/fuzz_targets/` (cargo-fuzz, libFuzzer) call these,
//! and `tests/fuzz_regressions.rs` replays the inputs in
//! `fuzz/regressions/<target>/` through them, so a bug the fuzzer found
//! stays fixed without a nightly toolchain. A harness ignores whether the
//! parser accepted the input: only a panic, an abort, a hang or a runaway
//! allocation is a bug. See `docs/fuzzing.md`.
//!
//! Parsers that only take paths get the bytes in a fresh scratch folder
//! that is removed afterwards. No input may read files it was not given:
//! scene files resolve names only inside a small fixed folder
//! ([`sandbox_dir`]), glTF inputs must name their buffers and images by
//! plain file names or `data:` URIs, and Lua scripts are confined to their
//! own folder (as `yubin render` confines them) and run under an
//! instruction and memory budget.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

thread_local! {
    /// The folder file names must resolve into while a harness runs.
    static SANDBOX: RefCell<Option<PathBuf>> = const { RefCell::new(None) };
}

/// Whether a harness confines file names to a folder that `path` lies
/// outside of. Always false outside the harnesses.
pub(crate) fn outside_sandbox(path: &Path) -> bool {
    SANDBOX.with_borrow(|root| {
        root.as_ref()
            .is_some_and(|root| !path.canonicalize().is_ok_and(|p| p.starts_with(root)))
    })
}

/// Confines file name resolution on this thread to `root` until dropped
/// (also when the parser panics, so a replaying test thread stays clean).
struct Confined;

impl Confined {
    fn to(root: &Path) -> Self {
        SANDBOX.with_borrow_mut(|r| *r = Some(root.to_path_buf()));
        Confined
    }
}

impl Drop for Confined {
    fn drop(&mut self) {
        SANDBOX.with_borrow_mut(|r| *r = None);
    }
}

/// A fresh folder for one input, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Self {
        static COUNT: AtomicU64 = AtomicU64::new(0);
        let n = COUNT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("yubin-fuzz-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("fuzz harness: cannot create a scratch folder");
        // Canonical, so that the Lua sandbox's prefix test sees the same
        // spelling as the paths it resolves.
        Scratch(dir.canonicalize().unwrap_or(dir))
    }

    /// Writes `data` to `name` in the folder and returns its path.
    fn file(&self, name: &str, data: &[u8]) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, data).expect("fuzz harness: cannot write the input file");
        path
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The folder scene inputs may read from: a few tiny files of each kind a
/// scene can name (`a.xml` includes itself, `part.xml` is a fragment,
/// `mesh.obj`, `mesh.ply`, `tex.pfm`, `grid.vol`), so that includes and
/// file references are exercised without reaching the rest of the disk.
/// Shared by all processes (a fuzzer in fork mode starts many), and
/// written once by each: every file is renamed into place whole, so a
/// reader never sees one half-written.
pub fn sandbox_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join("yubin-fuzz-sandbox-1");
        std::fs::create_dir_all(&dir).expect("fuzz harness: cannot create the sandbox folder");
        let mut pfm = b"PF\n1 1\n-1.0\n".to_vec();
        for v in [0.25f32, 0.5, 0.75] {
            pfm.extend_from_slice(&v.to_le_bytes());
        }
        let mut vol = b"VOL\x03".to_vec();
        for v in [1i32, 2, 1, 1, 1] {
            vol.extend_from_slice(&v.to_le_bytes());
        }
        for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0, 0.5, 1.0] {
            vol.extend_from_slice(&v.to_le_bytes());
        }
        let files: [(&str, &[u8]); 6] = [
            (
                "a.xml",
                b"<scene version=\"3.0.0\">\n<include filename=\"a.xml\"/>\n</scene>\n",
            ),
            ("part.xml", b"<bsdf type=\"diffuse\" id=\"part\"/>\n"),
            (
                "mesh.obj",
                b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
            ),
            (
                "mesh.ply",
                b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                  property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                  end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            ),
            ("tex.pfm", &pfm),
            ("grid.vol", &vol),
        ];
        for (name, data) in files {
            let part = dir.join(format!("{name}.{}", std::process::id()));
            std::fs::write(&part, data)
                .and_then(|()| std::fs::rename(&part, dir.join(name)))
                .expect("fuzz harness: cannot write the sandbox files");
        }
        dir.canonicalize().unwrap_or(dir)
    })
}

/// A Mitsuba XML scene, parsed and built. Names resolve in
/// [`sandbox_dir`] only.
pub fn xml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let dir = sandbox_dir();
    let _confined = Confined::to(dir);
    let _ = crate::load_scene_str(text, &dir.join("scene.xml"), &[]);
}

/// A Wavefront OBJ file, both ways of reading texture coordinates.
pub fn obj(data: &[u8]) {
    let scratch = Scratch::new();
    let path = scratch.file("mesh.obj", data);
    let _ = crate::mesh::obj::load_obj(&path, true);
}

/// A PLY file, ASCII or binary.
pub fn ply(data: &[u8]) {
    let scratch = Scratch::new();
    let path = scratch.file("mesh.ply", data);
    let _ = crate::mesh::ply::load_ply(&path);
}

/// A Mitsuba `serialized` file: its first and second mesh, which read the
/// table of mesh offsets differently.
pub fn serialized(data: &[u8]) {
    let scratch = Scratch::new();
    let path = scratch.file("mesh.serialized", data);
    for shape_index in [0, 1] {
        let _ = crate::mesh::serialized::load_serialized(&path, shape_index);
    }
}

/// An image file (EXR, PFM, PNG, JPEG, HDR, BMP, TGA; recognised by its
/// content), read as a texture and as an image.
pub fn image(data: &[u8]) {
    let scratch = Scratch::new();
    let path = scratch.file("image", data);
    // The loaders catch the panics of a decoder they guard (the `exr`
    // crate's B44 decoder overflows on damaged blocks): those are errors,
    // not crashes. libFuzzer's panic hook aborts on any panic, caught or
    // not, so it is set aside while the loaders run; a panic that gets out
    // of them is still a crash.
    let fuzzer_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let escaped = std::panic::catch_unwind(|| {
        let _ = crate::image_io::read_texture(&path);
        let _ = crate::image_io::read_image(&path, crate::image_io::ColorHandling::Srgb);
    })
    .is_err();
    std::panic::set_hook(fuzzer_hook);
    if escaped {
        panic!("an image loader panicked");
    }
}

/// A Mitsuba `.vol` grid.
pub fn vol(data: &[u8]) {
    let _ = crate::volume_io::parse_vol(data);
}

/// A glTF file (`.gltf` JSON or `.glb`), loaded and built as `yubin render
/// model.gltf` does, at a small resolution.
pub fn gltf(data: &[u8]) {
    if names_outside_files(data) {
        return;
    }
    let scratch = Scratch::new();
    let path = scratch.file("model.gltf", data);
    let options = crate::gltf::GltfOptions {
        width: Some(16),
        height: Some(16),
        spp: Some(1),
        env: None,
    };
    let _ = crate::gltf::load_gltf(&path, &options);
}

/// Whether a glTF input names a buffer or image file by anything but a
/// plain name in its own folder: those would be read from anywhere.
fn names_outside_files(data: &[u8]) -> bool {
    // The loader refuses what the `gltf` crate would panic on before it
    // parses; so must this look ahead.
    let at = crate::Location::new(std::sync::Arc::new(PathBuf::new()), 0);
    if crate::gltf::check_glb_length(data, &at).is_err() {
        return false;
    }
    let Ok(gltf) = gltf::Gltf::from_slice_without_validation(data) else {
        return false;
    };
    let json = gltf.document.as_json();
    let buffers = json.buffers.iter().filter_map(|b| b.uri.as_deref());
    let images = json.images.iter().filter_map(|i| i.uri.as_deref());
    buffers.chain(images).any(|uri| {
        !uri.starts_with("data:")
            && (uri.contains(['/', '\\', ':', '%']) || uri.starts_with('.') || uri.is_empty())
    })
}

/// Lua instructions a fuzzed script may run: far more than any scene
/// script needs, few enough to end an endless loop in a fraction of a
/// second.
const LUA_INSTRUCTIONS: u64 = 10_000_000;

/// Memory a fuzzed script's Lua state may hold.
const LUA_MEMORY: usize = 256 << 20;

/// A Lua scene script, run and its scene built, confined to its folder and
/// under an instruction and memory budget.
pub fn lua(data: &[u8]) {
    let scratch = Scratch::new();
    let path = scratch.file("scene.lua", data);
    // `gr.load` checks its own path, not the includes of the scene it loads.
    let _confined = Confined::to(&scratch.0);
    let limits = crate::lua::Limits {
        instructions: Some(LUA_INSTRUCTIONS),
        memory: Some(LUA_MEMORY),
    };
    let options = crate::lua::LuaOptions::default();
    if let Ok(scene) = crate::lua::run_lua_limited(&path, &options, None, limits) {
        let _ = crate::build::build_scene(&scene.desc);
    }
}
