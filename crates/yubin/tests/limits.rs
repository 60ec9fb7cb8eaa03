//! Files that ask for too much get a clear error at once, in bounded
//! memory: a PLY header claiming 10¹² faces (ASCII and binary) or 10¹²
//! vertices, an XML file that includes itself, a 100000 × 100000 film, a
//! texture whose header claims 10⁶ × 10⁶ texels. Each run is limited to
//! 1 GiB of address space (an allocation of what the file claims would
//! abort) and must end within a second, exit 1, with the file and the
//! limit (and how to raise it) in the message. `--limit` raises a limit.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-limits-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `yubin render SCENE --spp 1 -o out.exr EXTRA...` in `dir` with
/// 1 GiB of address space; returns the exit code, stderr and wall time.
fn render_bounded(dir: &Path, scene: &str, extra: &[&str]) -> (Option<i32>, String, Duration) {
    let start = Instant::now();
    let out = Command::new("sh")
        .current_dir(dir)
        .arg("-c")
        .arg(r#"ulimit -v 1048576 && exec "$0" render "$@""#)
        .arg(env!("CARGO_BIN_EXE_yubin"))
        .args([scene, "--spp", "1", "-o", "out.exr"])
        .args(extra)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        start.elapsed(),
    )
}

/// Asserts a clear, quick refusal whose message holds every one of `words`.
fn refused(dir: &Path, scene: &str, extra: &[&str], words: &[&str]) {
    let (code, stderr, took) = render_bounded(dir, scene, extra);
    println!("{scene}: {stderr} ({:.3} s)", took.as_secs_f64());
    assert_eq!(code, Some(1), "{scene}: {stderr}");
    for w in words {
        assert!(stderr.contains(w), "{scene}: no \"{w}\" in {stderr}");
    }
    assert!(
        took < Duration::from_secs(1),
        "{scene}: took {:.2} s",
        took.as_secs_f64()
    );
    assert!(!dir.join("out.exr").exists());
}

const PLY_HEAD: &str = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
const FACE: &str = "property list uchar int vertex_indices\nend_header\n";

fn shape_scene(dir: &Path, name: &str, shape: &str) -> String {
    let file = format!("{name}.xml");
    std::fs::write(
        dir.join(&file),
        format!(r#"<scene version="3.0.0">{shape}</scene>"#),
    )
    .unwrap();
    file
}

#[test]
fn meshes_claiming_more_than_their_files_hold_are_refused() {
    let d = dir("ply");
    let ascii = format!(
        "ply\nformat ascii 1.0\n{PLY_HEAD}element face 1000000000000\n{FACE}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    );
    std::fs::write(d.join("faces.ply"), ascii).unwrap();
    let mut binary = format!(
        "ply\nformat binary_little_endian 1.0\n{PLY_HEAD}element face 1000000000000\n{FACE}"
    )
    .into_bytes();
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        binary.extend(v.to_le_bytes());
    }
    binary.push(3);
    for i in [0i32, 1, 2] {
        binary.extend(i.to_le_bytes());
    }
    std::fs::write(d.join("binary.ply"), &binary).unwrap();
    let vertices = String::from_utf8_lossy(&binary).replace("vertex 3", "vertex 1000000000000");
    std::fs::write(d.join("vertices.ply"), vertices.as_bytes()).unwrap();
    for (ply, words) in [
        ("faces.ply", ["faces.ply", "1000000000000"]),
        ("binary.ply", ["binary.ply", "1000000000000"]),
        ("vertices.ply", ["vertices.ply", "1000000000000"]),
    ] {
        let scene = shape_scene(
            &d,
            ply,
            &format!(r#"<shape type="ply"><string name="filename" value="{ply}"/></shape>"#),
        );
        refused(&d, &scene, &[], &words);
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_file_that_includes_itself_is_refused() {
    let d = dir("include");
    std::fs::write(
        d.join("self.xml"),
        "<scene version=\"3.0.0\">\n<include filename=\"self.xml\"/>\n</scene>\n",
    )
    .unwrap();
    refused(&d, "self.xml", &[], &["self.xml:2", "includes itself"]);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_huge_film_is_refused_and_the_limit_can_be_raised() {
    let d = dir("film");
    let film = |w: u32, h: u32| {
        format!(
            r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/></film></sensor><shape type="sphere"/>"#
        )
    };
    let huge = shape_scene(&d, "huge", &film(100_000, 100_000));
    refused(
        &d,
        &huge,
        &[],
        &[
            "huge.xml",
            "100000 × 100000",
            "268435456",
            "--limit film-pixels=N",
        ],
    );
    // A crop window of it is a small render.
    let (code, stderr, _) = render_bounded(&d, &huge, &["--crop", "50000,50000,8,8"]);
    assert_eq!(code, Some(0), "{stderr}");
    std::fs::remove_file(d.join("out.exr")).unwrap();
    // Lowered, the limit refuses a small film; raised, it lets it by.
    let small = shape_scene(&d, "small", &film(16, 16));
    refused(
        &d,
        &small,
        &["--limit", "film-pixels=100"],
        &["limit of 100 pixels"],
    );
    let (code, stderr, _) = render_bounded(&d, &small, &["--limit", "film-pixels=256"]);
    assert_eq!(code, Some(0), "{stderr}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_texture_header_claiming_too_many_texels_is_refused() {
    let d = dir("texture");
    let mut pfm = b"PF\n1000000 1000000\n-1.0\n".to_vec();
    pfm.extend([0u8; 48]);
    std::fs::write(d.join("huge.pfm"), pfm).unwrap();
    let scene = shape_scene(
        &d,
        "textured",
        r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="huge.pfm"/></texture></bsdf></shape>"#,
    );
    refused(
        &d,
        &scene,
        &[],
        &["huge.pfm", "1000000 × 1000000", "--limit texture-pixels=N"],
    );
    std::fs::remove_dir_all(&d).ok();
}
