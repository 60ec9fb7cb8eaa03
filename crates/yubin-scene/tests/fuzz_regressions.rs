//! Replays the inputs the fuzzers found (`fuzz/regressions/<target>/`)
//! through the same harnesses (`yubin_scene::fuzzing`), so that a fixed
//! crash, hang or runaway allocation stays fixed without a nightly
//! toolchain. A test fails if an input panics or runs longer than
//! [`LIMIT`]; an input that aborts (stack overflow, allocation failure)
//! takes the whole test binary down, which fails it too. See
//! `docs/fuzzing.md`.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;
use yubin_scene::fuzzing;

/// Far above what any of these inputs takes once fixed (milliseconds),
/// and the fuzzers' own `-timeout`.
const LIMIT: Duration = Duration::from_secs(10);

/// A harness: the bytes of one input.
type Harness = fn(&[u8]);

/// The harness of each target, by its `fuzz/fuzz_targets` name.
const TARGETS: [(&str, Harness); 8] = [
    ("xml", fuzzing::xml),
    ("obj", fuzzing::obj),
    ("ply", fuzzing::ply),
    ("serialized", fuzzing::serialized),
    ("image", fuzzing::image),
    ("vol", fuzzing::vol),
    ("gltf", fuzzing::gltf),
    ("lua", fuzzing::lua),
];

/// Targets whose regressions another crate replays: the command line's
/// (`crates/yubin/tests/fuzz_arguments.rs`).
const ELSEWHERE: [&str; 1] = ["arguments"];

fn regressions_dir(target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/regressions")
        .join(target)
}

/// The files directly in `dir`, sorted; none if it does not exist.
fn files_in(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

fn harness(target: &str) -> Harness {
    TARGETS.iter().find(|(t, _)| *t == target).unwrap().1
}

/// Runs `harness` on the file in a thread of its own (with the 8 MiB stack
/// the fuzzer's main thread has), so that a hang is a failure after
/// [`LIMIT`] instead of a test that never ends. The error says why.
fn replay_file(harness: Harness, file: &Path) -> Result<(), String> {
    let data = std::fs::read(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let (done, finished) = mpsc::channel();
    std::thread::Builder::new()
        .name(file.display().to_string())
        .stack_size(8 << 20)
        .spawn(move || {
            let ok = std::panic::catch_unwind(|| harness(&data)).is_ok();
            let _ = done.send(ok);
        })
        .map_err(|e| format!("cannot start a thread: {e}"))?;
    match finished.recv_timeout(LIMIT) {
        Ok(true) => Ok(()),
        Ok(false) => Err(format!("{}: panicked", file.display())),
        Err(_) => Err(format!(
            "{}: still running after {} s",
            file.display(),
            LIMIT.as_secs()
        )),
    }
}

/// Replays every regression input of `target`.
fn replay(target: &str) {
    let failures: Vec<String> = files_in(&regressions_dir(target))
        .iter()
        .filter_map(|f| replay_file(harness(target), f).err())
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_regression_folder_names_a_target() {
    let root = regressions_dir("");
    for entry in std::fs::read_dir(&root).unwrap() {
        let entry = entry.unwrap();
        if !entry.path().is_dir() {
            continue;
        }
        let name = entry.file_name().to_string_lossy().into_owned();
        assert!(
            TARGETS.iter().any(|(t, _)| *t == name) || ELSEWHERE.contains(&name.as_str()),
            "fuzz/regressions/{name} is no fuzz target (its inputs would never be replayed)"
        );
    }
}

/// The committed seeds load without trouble too: the harnesses work on
/// the stable toolchain, and a seed that crashed would stop every fuzzer
/// at its first input.
#[test]
fn seeds() {
    let seeds = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/seeds");
    let mut failures = Vec::new();
    for (target, harness) in TARGETS {
        let files = files_in(&seeds.join(target));
        assert!(!files.is_empty(), "fuzz/seeds/{target} has no seeds");
        failures.extend(files.iter().filter_map(|f| replay_file(harness, f).err()));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn xml() {
    replay("xml");
}

#[test]
fn obj() {
    replay("obj");
}

#[test]
fn ply() {
    replay("ply");
}

#[test]
fn serialized() {
    replay("serialized");
}

#[test]
fn image() {
    replay("image");
}

#[test]
fn vol() {
    replay("vol");
}

#[test]
fn gltf() {
    replay("gltf");
}

#[test]
fn lua() {
    replay("lua");
}

/// The image fuzzer's out-of-memory finds: EXR headers claiming gigabytes
/// of samples in files of 20 KB, which the `exr` crate allocated before
/// reading (past the fuzzer's 2 GiB). In-process replay has no memory cap
/// to catch that, so the error itself is checked: refused before
/// decoding, saying why.
#[test]
fn image_headers_that_outgrow_their_files_are_refused() {
    let dir = std::env::temp_dir().join(format!("yubin-exr-oom-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let inputs: Vec<PathBuf> = files_in(&regressions_dir("image"))
        .into_iter()
        .filter(|f| {
            f.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("exr-header-outgrows")
        })
        .collect();
    assert!(!inputs.is_empty());
    for input in inputs {
        let exr = dir.join("input.exr");
        std::fs::copy(&input, &exr).unwrap();
        let err = match yubin_scene::image_io::read_texture(&exr) {
            Ok(_) => panic!("{} loaded", input.display()),
            Err(e) => e.to_string(),
        };
        assert!(err.contains("can hold"), "{}: {err}", input.display());
    }
    std::fs::remove_dir_all(&dir).ok();
}
