//! `yubin render --part K/N` and `yubin merge`: the parts of a render put
//! together are the file one `yubin render` writes, byte for byte (EXR
//! and PNG, with extra layers, under a crop window); parts that do not
//! belong together are refused, each named, exit 1, nothing written; a
//! part stopped by SIGTERM continues from its state when run again.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-merge-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const SCENE: [&str; 7] = [
    "render", "-D", "resx=45", "-D", "resy=38", "--quiet", "--seed=3",
];

fn yubin(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn render(dir: &Path, extra: &[&str]) -> Output {
    let args: Vec<&str> = SCENE.iter().chain(extra).copied().collect();
    yubin(dir, &args)
}

fn parts(dir: &Path, n: u32, extra: &[&str], name: &str) -> Vec<String> {
    (0..n)
        .map(|k| {
            let file = format!("{name}_{k}.exr");
            let part = format!("{k}/{n}");
            let args: Vec<&str> = extra
                .iter()
                .copied()
                .chain(["--part", &part, "-o", &file])
                .collect();
            ok(&render(dir, &args));
            file
        })
        .collect()
}

fn merge(dir: &Path, parts: &[String], output: &str) -> Output {
    let mut args = vec!["merge", "-q", "-o", output];
    args.extend(parts.iter().map(String::as_str));
    yubin(dir, &args)
}

fn same_bytes(dir: &Path, a: &str, b: &str) -> bool {
    std::fs::read(dir.join(a)).unwrap() == std::fs::read(dir.join(b)).unwrap()
}

#[test]
fn merged_parts_are_the_render_byte_for_byte() {
    let d = dir("identical");
    let cases: [&[&str]; 3] = [
        // The scene's Gaussian filter reaches across tiles.
        &["--spp", "37", "-D", "rfilter=gaussian"],
        // Extra layers, a crop window with partial tiles.
        &[
            "--spp",
            "9",
            "--aov",
            "albedo,normal,depth",
            "--crop",
            "3,5,40,30",
        ],
        // The default (tent) filter.
        &["--spp", "16"],
    ];
    for (c, extra) in cases.iter().enumerate() {
        let whole = format!("whole_{c}.exr");
        let args: Vec<&str> = extra.iter().copied().chain(["-o", &whole]).collect();
        ok(&render(&d, &args));
        for n in [1, 2, 5] {
            let files = parts(&d, n, extra, &format!("c{c}n{n}"));
            let merged = format!("merged_{c}_{n}.exr");
            ok(&merge(&d, &files, &merged));
            assert!(
                same_bytes(&d, &whole, &merged),
                "case {c}: {n} parts merged differ from one render"
            );
        }
    }
    // PNG output through the same view.
    ok(&render(&d, &["--spp", "16", "-o", "whole.png"]));
    let files = parts(&d, 3, &["--spp", "16"], "png");
    ok(&merge(&d, &files, "merged.png"));
    assert!(same_bytes(&d, "whole.png", "merged.png"));
    std::fs::remove_dir_all(&d).ok();
}

/// The error of `yubin merge` on `parts`, after checking that it failed
/// and wrote nothing.
fn refused(d: &Path, parts: &[String]) -> String {
    let out = merge(d, parts, "refused.exr");
    assert_eq!(out.status.code(), Some(1), "merge of {parts:?} must fail");
    assert!(
        !d.join("refused.exr").exists(),
        "a refused merge wrote its image"
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn parts_that_do_not_belong_together_are_refused_by_name() {
    let d = dir("refused");
    let good = parts(&d, 3, &["--spp", "8"], "good");
    let more_spp = parts(&d, 3, &["--spp", "9"], "spp");
    let other_scene = parts(&d, 3, &["--spp", "8", "-D", "resx=46"], "scene");
    let four = parts(&d, 4, &["--spp", "8"], "four");
    let missing = refused(&d, &good[..2]);
    assert!(missing.contains("part 2 of 3 missing"), "{missing}");
    let twice = refused(&d, &[good[0].clone(), good[1].clone(), good[1].clone()]);
    assert!(twice.contains("part 1/3 is given 2 times"), "{twice}");
    let spp = refused(&d, &[good[0].clone(), good[1].clone(), more_spp[2].clone()]);
    assert!(
        spp.contains(
            "spp_2.exr and good_0.exr differ in spp: \"9\" in spp_2.exr, \"8\" in good_0.exr"
        ),
        "{spp}"
    );
    let scene = refused(
        &d,
        &[good[0].clone(), other_scene[1].clone(), good[2].clone()],
    );
    assert!(
        scene.contains("scene_1.exr and good_0.exr differ") && scene.contains("defines"),
        "{scene}"
    );
    let count = refused(&d, &[good[0].clone(), good[1].clone(), four[2].clone()]);
    assert!(count.contains("four_2.exr is part 2/4"), "{count}");
    // A part of another yubin version: its header rewritten.
    let old = d.join("old_2.exr");
    rewrite_attribute(&d.join(&good[2]), &old, "yubin.version", "0.0.1");
    let version = refused(&d, &[good[0].clone(), good[1].clone(), "old_2.exr".into()]);
    assert!(
        version.contains("old_2.exr was rendered by yubin 0.0.1"),
        "{version}"
    );
    // Not a part file at all, and a file that does not exist.
    ok(&render(&d, &["--spp", "8", "-o", "image.exr"]));
    let image = refused(&d, &[good[0].clone(), "image.exr".into()]);
    assert!(
        image.contains("image.exr: not a yubin part file"),
        "{image}"
    );
    let absent = refused(&d, &[good[0].clone(), "absent.exr".into()]);
    assert!(absent.contains("absent.exr"), "{absent}");
    // The good ones merge.
    ok(&merge(&d, &good, "good.exr"));
    std::fs::remove_dir_all(&d).ok();
}

/// Copies the part file `from` to `to` with `key` set to `value`.
fn rewrite_attribute(from: &Path, to: &Path, key: &str, value: &str) {
    use exr::prelude::{AttributeValue, Text, WritableImage};
    let mut image = exr::prelude::read_first_flat_layer_from_file(from).unwrap();
    image
        .layer_data
        .attributes
        .other
        .insert(Text::from(key), AttributeValue::Text(Text::from(value)));
    image.write().to_file(to).unwrap();
}

#[test]
fn a_part_stopped_by_sigterm_continues_when_run_again() {
    let d = dir("resume");
    let extra = ["--spp", "6000", "-D", "resx=32", "-D", "resy=32"];
    let with = |more: &[&'static str]| -> Vec<&str> {
        SCENE.iter().chain(&extra).chain(more).copied().collect()
    };
    let args = with(&["--threads", "1", "--part", "1/2", "-o", "part_1.exr"]);
    let child = Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(&d)
        .args(&args)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_secs(1));
    kill_term(child.id());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(143));
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("part 1/2 saved to"), "{said}");
    assert!(
        !d.join("part_1.exr").exists(),
        "an unfinished part was written"
    );
    assert!(d.join("part_1.exr.state").exists());
    // Run again, it finishes from the state (and removes it).
    let again = yubin(&d, &args);
    ok(&again);
    assert!(!d.join("part_1.exr.state").exists());
    ok(&yubin(&d, &with(&["--part", "0/2", "-o", "part_0.exr"])));
    ok(&merge(
        &d,
        &["part_0.exr".into(), "part_1.exr".into()],
        "merged.exr",
    ));
    ok(&yubin(&d, &with(&["-o", "whole.exr"])));
    assert!(same_bytes(&d, "whole.exr", "merged.exr"));
    std::fs::remove_dir_all(&d).ok();
}

fn kill_term(pid: u32) {
    let status = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status()
        .unwrap();
    assert!(status.success());
}

/// `--part` asks for an EXR output and a plain render's passes, refuses
/// what cannot be split, and takes its number from a scheduler.
#[test]
fn a_part_needs_an_exr_and_takes_its_number_from_the_scheduler() {
    let d = dir("options");
    let error = |args: &[&str]| {
        let out = render(&d, args);
        assert!(!out.status.success(), "{args:?} must fail");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    assert!(error(&["--part", "0/2"]).contains("--part needs -o PART.exr"));
    assert!(error(&["--part", "0/2", "-o", "p.png"]).contains("--part needs -o PART.exr"));
    let adaptive = error(&["--part", "0/2", "--adaptive", "0.1", "-o", "p.exr"]);
    assert!(
        adaptive.contains("--part cannot be used with --adaptive"),
        "{adaptive}"
    );
    assert!(error(&["--part", "4/4", "-o", "p.exr"]).contains("parts are numbered 0 to 3"));
    let unset = Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(&d)
        .args(SCENE)
        .args(["--spp", "4", "--part", "auto/4", "-o", "p.exr"])
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .env_remove("AWS_BATCH_JOB_ARRAY_INDEX")
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&unset.stderr);
    assert!(said.contains("none of SLURM_ARRAY_TASK_ID"), "{said}");
    // Kubernetes' index makes this part 3 of 4.
    let indexed = Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(&d)
        .args(SCENE)
        .args(["--spp", "4", "--part", "auto/4", "-o", "p.exr"])
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env("JOB_COMPLETION_INDEX", "3")
        .output()
        .unwrap();
    ok(&indexed);
    let alone = refused(&d, &["p.exr".into()]);
    assert!(alone.contains("parts 0, 1, 2 of 4 missing"), "{alone}");
    std::fs::remove_dir_all(&d).ok();
}
