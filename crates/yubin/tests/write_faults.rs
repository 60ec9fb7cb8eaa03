//! A write that fails leaves the previous output as it was: the render is
//! run under a file size limit smaller than its image (`ulimit -f`, with
//! SIGXFSZ ignored so that the write fails with EFBIG, as on a full
//! disk), for EXR and PNG. It exits 1 saying the previous file is
//! untouched, the file is byte for byte the earlier one, and no
//! temporary file is left beside it.

use std::path::{Path, PathBuf};
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-write-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `yubin render` of the built-in scene at 64 × 64 into `out`, under a
/// file size limit of `blocks` blocks when given.
fn render(dir: &Path, out: &str, spp: &str, blocks: Option<u32>) -> (Option<i32>, String) {
    let limit = blocks.map_or(String::new(), |b| format!("ulimit -f {b} && "));
    let out = Command::new("sh")
        .current_dir(dir)
        .arg("-c")
        .arg(format!(r#"trap '' XFSZ && {limit}exec "$0" "$@""#))
        .arg(env!("CARGO_BIN_EXE_yubin"))
        .args([
            "render", "-D", "resx=64", "-D", "resy=64", "--spp", spp, "-q", "-o", out,
        ])
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_failed_write_keeps_the_previous_output() {
    let d = dir("full");
    for name in ["image.exr", "image.png"] {
        let (code, stderr) = render(&d, name, "1", None);
        assert_eq!(code, Some(0), "{stderr}");
        let before = std::fs::read(d.join(name)).unwrap();
        assert!(before.len() > 4096, "{name}: too small to test");
        // 4 blocks (2 or 4 KiB, by the shell's unit): the image does not fit.
        let (code, stderr) = render(&d, name, "2", Some(4));
        println!("{name}: {stderr}");
        assert_eq!(code, Some(1), "{name}: {stderr}");
        assert!(
            stderr.contains(&format!("the previous {name} is untouched")),
            "{name}: {stderr}"
        );
        assert_eq!(
            std::fs::read(d.join(name)).unwrap(),
            before,
            "{name} changed"
        );
        let left: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp"))
            .collect();
        assert!(left.is_empty(), "temporary files left: {left:?}");
    }
    std::fs::remove_dir_all(&d).ok();
}
