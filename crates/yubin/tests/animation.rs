//! `yubin render scene.lua --frames A-B --video out.mp4`: the example
//! animation renders to numbered frames, a frame rendered alone equals the
//! same frame of the sequence, and (where ffmpeg is installed) the video
//! has every frame.

use std::path::{Path, PathBuf};
use std::process::Command;

fn yubin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_yubin"))
}

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/animation/bounce.lua")
}

fn has(tool: &str) -> bool {
    Command::new(tool)
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success())
}

#[test]
fn the_example_renders_its_frames_and_video() {
    let dir = std::env::temp_dir().join(format!("yubin-animation-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let pattern = dir.join("frame_####.png");
    let video = dir.join("bounce.mp4");
    let with_video = has("ffmpeg") && has("ffprobe");
    let mut cmd = yubin();
    cmd.arg("render")
        .arg(example())
        .args(["--frames", "1-24", "--spp", "2", "-q", "-o"])
        .arg(&pattern);
    if with_video {
        cmd.arg("--video").arg(&video);
    }
    let status = cmd.status().unwrap();
    assert!(status.success(), "the animation failed: {status}");
    for n in 1..=24 {
        assert!(
            dir.join(format!("frame_{n:04}.png")).is_file(),
            "frame {n} missing"
        );
    }
    // Frame 7 alone is frame 7 of the sequence.
    let alone = dir.join("alone_####.png");
    let status = yubin()
        .arg("render")
        .arg(example())
        .args(["--frames", "7", "--spp", "2", "-q", "-o"])
        .arg(&alone)
        .status()
        .unwrap();
    assert!(status.success());
    let a = std::fs::read(dir.join("alone_0007.png")).unwrap();
    let b = std::fs::read(dir.join("frame_0007.png")).unwrap();
    assert!(a == b, "frame 7 alone differs from frame 7 of the sequence");
    if !with_video {
        println!("video skipped: ffmpeg and ffprobe are not installed (apt-get install ffmpeg)");
        return;
    }
    let probe = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=nb_read_frames", "-of", "csv=p=0"])
        .arg(&video)
        .output()
        .unwrap();
    let frames = String::from_utf8_lossy(&probe.stdout).trim().to_string();
    assert_eq!(
        frames,
        "24",
        "ffprobe counts {frames} frames in {}",
        video.display()
    );
}

#[test]
fn a_video_without_ffmpeg_or_frames_is_a_clear_error() {
    let out = yubin()
        .arg("render")
        .arg(example())
        .args(["--video", "x.mp4"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--frames"), "{err}");
}
