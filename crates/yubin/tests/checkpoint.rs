//! Checkpoint and resume: a render interrupted by SIGINT (exit 130) or
//! SIGTERM (exit 143) writes its state and the image so far; resumed with
//! `--resume`, it finishes bit-identical to an uninterrupted render and
//! removes the state. A resume with other settings, and a damaged
//! checkpoint, are refused with a message saying why.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};
use yubin_scene::image_io::{read_image, ColorHandling};

const ARGS: [&str; 10] = [
    "render",
    "-D",
    "resx=32",
    "-D",
    "resy=32",
    "--spp",
    "2048",
    "--pass-spp",
    "4",
    "--quiet",
];

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-ckpt-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn yubin(dir: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_yubin"));
    c.current_dir(dir).args(ARGS).args(extra);
    c
}

fn run(dir: &Path, extra: &[&str]) -> Output {
    yubin(dir, extra).output().unwrap()
}

/// Starts a checkpointed render, waits for its first checkpoint, sends
/// `signal` and returns the exit code.
fn interrupt(dir: &Path, signal: &str) -> Option<i32> {
    let mut child: Child = yubin(dir, &["--checkpoint", "0.05", "-o", "out.exr"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let state = dir.join("out.exr.state");
    let start = Instant::now();
    while !state.exists() {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "no checkpoint appeared"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let pid = child.id().to_string();
    let killed = Command::new("kill").args([signal, &pid]).status().unwrap();
    assert!(killed.success());
    child.wait().unwrap().code()
}

fn pixels(path: &Path) -> Vec<f32> {
    read_image(path, ColorHandling::Raw).unwrap().data
}

#[test]
fn interrupted_and_resumed_equals_uninterrupted() {
    let d = dir("resume");
    // The same command, left to finish (its checkpoints never come).
    let whole = run(&d, &["--checkpoint", "1000", "-o", "whole.exr"]);
    assert!(whole.status.success());
    for (signal, code) in [("-INT", 130), ("-TERM", 143)] {
        assert_eq!(interrupt(&d, signal), Some(code), "{signal}");
        assert!(d.join("out.exr").exists() && d.join("out.exr.state").exists());
        let partial = pixels(&d.join("out.exr"));
        assert_ne!(
            partial,
            pixels(&d.join("whole.exr")),
            "{signal}: it finished before the signal"
        );
        let resumed = run(&d, &["--resume", "out.exr.state", "-o", "out.exr"]);
        assert!(
            resumed.status.success(),
            "{}",
            String::from_utf8_lossy(&resumed.stderr)
        );
        let (a, b) = (pixels(&d.join("out.exr")), pixels(&d.join("whole.exr")));
        assert!(
            a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{signal}: the resumed render differs from the uninterrupted one"
        );
        assert!(
            !d.join("out.exr.state").exists(),
            "the finished render kept its state"
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn resuming_another_render_or_a_damaged_state_is_refused() {
    let d = dir("refuse");
    assert_eq!(interrupt(&d, "-INT"), Some(130));
    let other = run(
        &d,
        &[
            "--seed",
            "5",
            "--resume",
            "out.exr.state",
            "-o",
            "other.exr",
        ],
    );
    assert_eq!(other.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&other.stderr);
    assert!(
        stderr.contains("seed") && stderr.contains("\"5\" now"),
        "{stderr}"
    );
    assert!(!d.join("other.exr").exists());
    let mut bytes = std::fs::read(d.join("out.exr.state")).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x40;
    std::fs::write(d.join("damaged.state"), &bytes).unwrap();
    let damaged = run(&d, &["--resume", "damaged.state", "-o", "x.exr"]);
    assert_eq!(damaged.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&damaged.stderr);
    assert!(
        stderr.contains("damaged.state") && stderr.contains("checksum"),
        "{stderr}"
    );
    assert!(!d.join("x.exr").exists());
    std::fs::remove_dir_all(&d).ok();
}
