//! `yubin farm slurm` through a real Slurm: the single-node cluster of
//! `scripts/slurm-local start` (which `.ci/run` starts). Elsewhere the
//! tests say why they skip: they submit jobs, and must never reach a
//! cluster of real users.
//!
//! - A render as 4 parts merges to the file one `yubin render` writes.
//! - A task cancelled mid-render: the merge job never runs on the
//!   incomplete set (Slurm cancels it), `farm status` shows the part
//!   interrupted, and `farm resubmit` finishes it from its saved state into
//!   the same file.
//! - A 6-frame Lua animation in 2 parts a frame: every frame equals its
//!   frame of `yubin render --frames`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The test cluster's config, or why there is none.
fn test_cluster() -> Result<PathBuf, String> {
    let conf = std::env::var_os("SLURM_CONF")
        .ok_or("SLURM_CONF is not set (run: eval \"$(scripts/slurm-local start)\")")?;
    let text = std::fs::read_to_string(&conf).map_err(|e| format!("SLURM_CONF: {e}"))?;
    if !text.contains("ClusterName=yubin-test") {
        return Err("SLURM_CONF is not scripts/slurm-local's test cluster".into());
    }
    let up = Command::new("sinfo")
        .output()
        .is_ok_and(|o| o.status.success());
    if !up {
        return Err("sinfo fails: the test cluster is not running".into());
    }
    Ok(conf.into())
}

macro_rules! needs_cluster {
    () => {
        if let Err(why) = test_cluster() {
            println!("skipped: {why}");
            return;
        }
    };
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-farm-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn yubin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_yubin"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: Output) -> String {
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The render and merge job ids `farm slurm --submit` recorded.
fn jobs(farm: &Path) -> (String, String) {
    let text = std::fs::read_to_string(farm.join("jobs")).unwrap();
    let ids: Vec<&str> = text.split_whitespace().collect();
    (ids[0].to_string(), ids[1].to_string())
}

/// `JobState` of each line `scontrol show job` prints for `job` (one per
/// array task), empty once Slurm has forgotten it.
fn job_states(job: &str) -> Vec<String> {
    let out = Command::new("scontrol")
        .args(["-o", "show", "job", job])
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            l.split_whitespace()
                .find_map(|w| w.strip_prefix("JobState="))
                .map(str::to_string)
        })
        .collect()
}

/// Waits until every line of `job` is in a final state; returns them.
fn wait_for(job: &str) -> Vec<String> {
    let start = Instant::now();
    let finished = |s: &String| {
        [
            "COMPLETED",
            "FAILED",
            "CANCELLED",
            "TIMEOUT",
            "NODE_FAIL",
            "OUT_OF_MEMORY",
        ]
        .contains(&s.as_str())
    };
    loop {
        let states = job_states(job);
        if !states.is_empty() && states.iter().all(finished) {
            return states;
        }
        assert!(
            start.elapsed() < Duration::from_secs(180),
            "job {job} still not finished: {states:?}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn same_bytes(a: &Path, b: &Path) -> bool {
    std::fs::read(a).unwrap() == std::fs::read(b).unwrap()
}

const CORNELL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/cornell-box.xml");

/// `yubin farm slurm SCENE --parts N -o FARM FARM_OPTIONS --submit --
/// OPTIONS`: what it printed.
fn submit(
    scene: &str,
    parts: &str,
    farm: &Path,
    farm_options: &[&str],
    options: &[&str],
) -> String {
    let mut args = vec!["farm", "slurm", scene, "--parts", parts, "-o", path(farm)];
    args.extend(farm_options);
    args.extend(["--submit", "--"]);
    args.extend(options);
    ok(yubin(&args))
}

/// `yubin render SCENE OPTIONS -q -o OUT` on this machine.
fn render_alone(scene: &str, options: &[&str], out: &Path) {
    let mut args = vec!["render", scene, "-q", "-o", path(out)];
    args.extend(options);
    ok(yubin(&args));
}

#[test]
fn four_parts_merge_to_one_render() {
    needs_cluster!();
    let d = dir("four");
    let farm = d.join("farm");
    let options = ["--spp", "24", "-D", "resx=72", "-D", "resy=40"];
    let printed = submit(CORNELL, "4", &farm, &[], &options);
    assert!(printed.contains("#SBATCH --array=0-3"), "{printed}");
    assert!(printed.contains("submitted: render job"), "{printed}");
    let (render, merge) = jobs(&farm);
    assert_eq!(wait_for(&render), ["COMPLETED"; 4]);
    assert_eq!(wait_for(&merge), ["COMPLETED"]);
    let single = d.join("single.exr");
    render_alone(CORNELL, &options, &single);
    assert!(
        same_bytes(&single, &farm.join("cornell-box.exr")),
        "the merged image differs from one render"
    );
    let status = ok(yubin(&["farm", "status", path(&farm)]));
    assert!(
        status.contains("(cornell-box.exr, merged)") && status.contains("4 done"),
        "{status}"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_cancelled_part_stops_the_merge_and_resubmitting_finishes_it() {
    needs_cluster!();
    let d = dir("cancel");
    let farm = d.join("farm");
    // Parts long enough (seconds on one core) to cancel one mid-render.
    let options = ["--spp", "8000", "-D", "resx=32", "-D", "resy=32"];
    submit(CORNELL, "2", &farm, &[], &options);
    let (render, merge) = jobs(&farm);
    let task = format!("{render}_1");
    let start = Instant::now();
    while job_states(&task) != ["RUNNING"] {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "task 1 never ran"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(1500));
    let cancelled = Command::new("scancel").arg(&task).status().unwrap();
    assert!(cancelled.success());
    wait_for(&render);
    // The merge never runs on an incomplete set: Slurm cancels it.
    assert_eq!(wait_for(&merge), ["CANCELLED"]);
    let image = farm.join("cornell-box.exr");
    assert!(!image.exists(), "the merge ran without part 1");
    let log = std::fs::read_to_string(farm.join("logs/task_1.log")).unwrap();
    assert!(log.contains("part 1/2 saved to"), "{log}");
    let status = ok(yubin(&["farm", "status", path(&farm)]));
    assert!(
        status.contains("part 1 (task 1): interrupted ("),
        "{status}"
    );
    assert!(status.contains("not merged"), "{status}");
    let again = ok(yubin(&["farm", "resubmit", path(&farm)]));
    assert!(again.contains("(tasks 1)"), "{again}");
    let (render, merge) = jobs(&farm);
    assert_eq!(wait_for(&render), ["COMPLETED"]);
    assert_eq!(wait_for(&merge), ["COMPLETED"]);
    let log = std::fs::read_to_string(farm.join("logs/task_1.log")).unwrap();
    assert!(log.contains("continuing from"), "{log}");
    let single = d.join("single.exr");
    render_alone(CORNELL, &options, &single);
    assert!(
        same_bytes(&single, &image),
        "the image finished after resubmitting differs from one render"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn an_animation_renders_every_frame() {
    needs_cluster!();
    let d = dir("frames");
    let farm = d.join("farm");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/animation/bounce.lua"
    );
    submit(scene, "2", &farm, &["--frames", "0-5"], &["--spp", "2"]);
    let (render, merge) = jobs(&farm);
    assert_eq!(wait_for(&render), ["COMPLETED"; 12]);
    assert_eq!(wait_for(&merge), ["COMPLETED"]);
    let frames = d.join("single_####.exr");
    render_alone(scene, &["--frames", "0-5", "--spp", "2"], &frames);
    for f in 0..6 {
        let single = d.join(format!("single_{f:04}.exr"));
        let merged = farm.join(format!("bounce_{f:04}.exr"));
        assert!(same_bytes(&single, &merged), "frame {f} differs");
    }
    std::fs::remove_dir_all(&d).ok();
}
