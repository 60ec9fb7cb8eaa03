//! Replays the command-line fuzz target's regressions
//! (`fuzz/regressions/arguments/`) and seeds (`fuzz/seeds/arguments/`)
//! through `yubin::fuzz_arguments`: none may panic. See `docs/fuzzing.md`.

use std::path::{Path, PathBuf};

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

#[test]
fn command_line_inputs_never_panic() {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    let seeds = files_in(&fuzz.join("seeds/arguments"));
    assert!(!seeds.is_empty(), "fuzz/seeds/arguments has no seeds");
    let inputs = seeds
        .into_iter()
        .chain(files_in(&fuzz.join("regressions/arguments")));
    let failures: Vec<String> = inputs
        .filter(|f| {
            let data = std::fs::read(f).unwrap();
            std::panic::catch_unwind(|| yubin::fuzz_arguments(&data)).is_err()
        })
        .map(|f| f.display().to_string())
        .collect();
    assert!(failures.is_empty(), "panicked: {failures:?}");
}
