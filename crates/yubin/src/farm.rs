//! `yubin farm`: a render (or an animation) as a Slurm job array of parts
//! and a merge job that runs once every part has succeeded.
//!
//! `yubin farm slurm SCENE --parts N -o DIR` writes into DIR:
//! `render.sbatch` (the array: one task per part of each frame, each
//! `yubin render --part K/N`), `merge.sbatch` (`yubin merge`, once per
//! frame), `submit.sh` (submits the two, the merge with
//! `--dependency=afterok` and `--kill-on-invalid-dep=yes`) and `farm.txt`
//! (what `status` and `resubmit` read); `--submit` submits them. Parts go
//! to DIR/parts, logs to DIR/logs, images to DIR. A task stopped by
//! SIGTERM (pre-emption, `scancel`) leaves its part's state, which the
//! task continues when it runs again (requeued, or `yubin farm resubmit`).

use crate::checkpoint;
use crate::part;
use crate::Cli;
use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Arguments of `yubin farm`.
#[derive(Debug, clap::Args)]
pub struct FarmArgs {
    #[command(subcommand)]
    command: FarmCommand,
}

#[derive(Debug, Subcommand)]
enum FarmCommand {
    /// Write (and with --submit, submit) the Slurm jobs of a render in
    /// parts: a job array over the parts, and a merge job that runs once
    /// they have all succeeded.
    Slurm(SlurmArgs),
    /// Which parts of a farm directory are done, running, pending,
    /// interrupted (their state saved) or missing, and which images are
    /// merged.
    Status(DirArgs),
    /// Submit again the parts of a farm directory that are neither done
    /// nor queued, and a merge job after them.
    Resubmit(ResubmitArgs),
}

/// `yubin farm slurm`.
#[derive(Debug, clap::Args)]
struct SlurmArgs {
    /// The scene (as `yubin render` takes it).
    scene: PathBuf,
    /// Parts each image is split into (array tasks per frame).
    #[arg(long, value_name = "N")]
    parts: u32,
    /// Lua scenes: the frames A-B (or one frame N) of the animation.
    #[arg(long, value_name = "A-B", value_parser = crate::render::parse_frames)]
    frames: Option<(i64, i64)>,
    /// The farm directory: the scripts, parts/, logs/ and the images.
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// The image's name in DIR (default: the scene's name with .exr;
    /// for --frames, with `_####` before it, `#` the frame number).
    #[arg(long, value_name = "NAME")]
    image: Option<String>,
    /// Slurm partition (sbatch --partition).
    #[arg(long, value_name = "P")]
    partition: Option<String>,
    /// Time limit of each task (sbatch --time: MM, HH:MM:SS, D-HH).
    #[arg(long, value_name = "T")]
    time: Option<String>,
    /// Cores of each task, which its render uses.
    #[arg(long, value_name = "C", default_value_t = 1)]
    cpus_per_task: u32,
    /// Another sbatch option for both jobs (--sbatch=--account=lab);
    /// repeatable.
    #[arg(long = "sbatch", value_name = "OPTION", allow_hyphen_values = true)]
    sbatch: Vec<String>,
    /// The yubin binary the tasks run (default: this one).
    #[arg(long, value_name = "PATH")]
    yubin: Option<PathBuf>,
    /// Submit the jobs (sbatch) and print their ids.
    #[arg(long)]
    submit: bool,
    /// Options of `yubin render` for every part, after `--`
    /// (`-- --spp 1024 -D res=2048`).
    #[arg(last = true, value_name = "RENDER OPTIONS")]
    render: Vec<String>,
}

/// A farm directory.
#[derive(Debug, clap::Args)]
struct DirArgs {
    /// The farm directory (`yubin farm slurm -o DIR`).
    dir: PathBuf,
}

/// `yubin farm resubmit`.
#[derive(Debug, clap::Args)]
struct ResubmitArgs {
    /// The farm directory (`yubin farm slurm -o DIR`).
    dir: PathBuf,
    /// Print the sbatch commands without running them.
    #[arg(long)]
    dry_run: bool,
}

/// Runs `yubin farm`.
pub fn run(args: FarmArgs) -> Result<()> {
    match args.command {
        FarmCommand::Slurm(a) => slurm(a),
        FarmCommand::Status(a) => status(&a.dir),
        FarmCommand::Resubmit(a) => resubmit(&a.dir, a.dry_run),
    }
}

/// What a farm directory holds, as `farm.txt` records it.
#[derive(Clone, Debug)]
struct Farm {
    dir: PathBuf,
    parts: u32,
    frames: Option<(i64, i64)>,
    /// The image's name in the directory (`#`s: the frame).
    image: String,
}

impl Farm {
    /// The frames (one, `None`, without an animation).
    fn frames(&self) -> Vec<Option<i64>> {
        match self.frames {
            Some((a, b)) => (a..=b).map(Some).collect(),
            None => vec![None],
        }
    }

    /// Array tasks: one per part of each frame.
    fn tasks(&self) -> u64 {
        self.frames().len() as u64 * u64::from(self.parts)
    }

    /// The frame and part of array task `task`.
    fn task(&self, task: u64) -> (Option<i64>, u32) {
        let part = (task % u64::from(self.parts)) as u32;
        let frame = self
            .frames
            .map(|(a, _)| a + (task / u64::from(self.parts)) as i64);
        (frame, part)
    }

    /// The part file of `part` of `frame`, relative to the directory.
    fn part_file(&self, frame: Option<i64>, part: u32) -> String {
        match frame {
            Some(f) => format!("parts/frame_{f:04}.part_{part}.exr"),
            None => format!("parts/part_{part}.exr"),
        }
    }

    /// The image of `frame`, relative to the directory.
    fn image_file(&self, frame: Option<i64>) -> String {
        match frame {
            Some(f) => numbered(&self.image, &format!("{f:04}")),
            None => self.image.clone(),
        }
    }

    fn manifest(&self) -> String {
        let frames = self
            .frames
            .map(|(a, b)| format!("{a}-{b}"))
            .unwrap_or_default();
        format!(
            "# yubin farm: read by `yubin farm status` and `yubin farm resubmit`\nparts={}\nframes={frames}\nimage={}\n",
            self.parts, self.image
        )
    }

    fn read(dir: &Path) -> Result<Farm> {
        let path = dir.join("farm.txt");
        let text = std::fs::read_to_string(&path).with_context(|| {
            format!(
                "{} is not a farm directory (no farm.txt: make one with yubin farm slurm)",
                dir.display()
            )
        })?;
        let value = |key: &str| {
            text.lines()
                .find_map(|l| l.strip_prefix(key)?.strip_prefix('='))
                .map(str::trim)
        };
        let bad = |key: &str| anyhow::anyhow!("{}: no usable {key}=", path.display());
        let parts = value("parts")
            .and_then(|v| v.parse().ok())
            .filter(|&n| n > 0)
            .ok_or_else(|| bad("parts"))?;
        let frames = match value("frames") {
            None | Some("") => None,
            Some(v) => Some(crate::render::parse_frames(v).map_err(|_| bad("frames"))?),
        };
        let image = value("image").ok_or_else(|| bad("image"))?.to_string();
        Ok(Farm {
            dir: dir.to_path_buf(),
            parts,
            frames,
            image,
        })
    }

    /// The job ids submitted last: the render array's and the merge's.
    fn jobs(&self) -> Option<(String, String)> {
        let text = std::fs::read_to_string(self.dir.join("jobs")).ok()?;
        let mut ids = text.split_whitespace();
        Some((ids.next()?.to_string(), ids.next()?.to_string()))
    }
}

/// `name` with its run of `#` replaced by `number`.
fn numbered(name: &str, number: &str) -> String {
    match name.find('#') {
        Some(start) => {
            let end = start + name[start..].chars().take_while(|&c| c == '#').count();
            format!("{}{number}{}", &name[..start], &name[end..])
        }
        None => name.to_string(),
    }
}

/// A word as the shell reads it literally.
fn quote(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

fn slurm(args: SlurmArgs) -> Result<()> {
    if args.parts == 0 {
        bail!("--parts must be at least 1");
    }
    if args.cpus_per_task == 0 {
        bail!("--cpus-per-task must be at least 1");
    }
    let scene = std::fs::canonicalize(&args.scene)
        .with_context(|| format!("cannot find the scene {}", args.scene.display()))?;
    check_render_options(&scene, &args)?;
    std::fs::create_dir_all(args.output.join("parts"))
        .and_then(|()| std::fs::create_dir_all(args.output.join("logs")))
        .with_context(|| format!("cannot make the farm directory {}", args.output.display()))?;
    let dir = std::fs::canonicalize(&args.output)?;
    let plain = |p: &Path| {
        !p.to_string_lossy()
            .chars()
            .any(|c| c.is_whitespace() || "\"'$`\\!".contains(c))
    };
    if !plain(&dir) || !plain(&scene) {
        bail!(
            "{}: a farm's directory and scene paths may not hold spaces, quotes, $, `, \\ or ! (Slurm's #SBATCH lines and the scripts take them as they are)",
            if plain(&dir) { scene.display() } else { dir.display() }
        );
    }
    let yubin = match &args.yubin {
        Some(p) => p.clone(),
        None => std::env::current_exe().context("cannot tell where this yubin is")?,
    };
    let stem = scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let image = args.image.clone().unwrap_or_else(|| match args.frames {
        Some(_) => format!("{stem}_####.exr"),
        None => format!("{stem}.exr"),
    });
    if args.frames.is_some() && !image.contains('#') {
        bail!("--image {image}: the frames' images need a run of '#' for the frame number");
    }
    let farm = Farm {
        dir: dir.clone(),
        parts: args.parts,
        frames: args.frames,
        image,
    };
    let files = [
        ("render.sbatch", render_script(&farm, &args, &scene, &yubin)),
        ("merge.sbatch", merge_script(&farm, &args, &yubin)),
        ("submit.sh", SUBMIT.to_string()),
        ("farm.txt", farm.manifest()),
    ];
    for (name, text) in &files {
        let path = dir.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
        if name.ends_with(".sh") || name.ends_with(".sbatch") {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755))?;
        }
    }
    for (name, text) in &files[..2] {
        println!("==> {} <==\n{text}", dir.join(name).display());
    }
    if args.submit {
        let (render, merge) = submit(&farm, None, None)?;
        println!(
            "submitted: render job {render} ({} tasks), merge job {merge}",
            farm.tasks()
        );
        println!(
            "follow it with: yubin farm status {}",
            quote(&dir.display().to_string())
        );
    } else {
        println!(
            "submit with: {}",
            quote(&dir.join("submit.sh").display().to_string())
        );
    }
    Ok(())
}

/// Refuses render options the farm sets itself, and any `yubin render`
/// would refuse, before a script is written.
fn check_render_options(scene: &Path, args: &SlurmArgs) -> Result<()> {
    let own = [
        "-o",
        "--output",
        "--part",
        "--frames",
        "--threads",
        "--video",
    ];
    if let Some(o) = args.render.iter().find(|a| {
        own.iter()
            .any(|o| *a == o || a.starts_with(&format!("{o}=")))
    }) {
        bail!("{o}: yubin farm sets it for each task (give the farm's own options before --)");
    }
    let mut line = vec![
        "yubin".to_string(),
        "render".into(),
        scene.display().to_string(),
    ];
    line.extend(args.render.iter().cloned());
    line.extend(["--part".into(), format!("0/{}", args.parts)]);
    if let Some((a, b)) = args.frames {
        line.extend(["--frames".into(), format!("{a}-{b}")]);
    }
    Cli::try_parse_from(&line)
        .map_err(|e| anyhow::anyhow!("the render options after -- are not yubin render's: {e}"))?;
    Ok(())
}

/// `#SBATCH` lines both jobs share.
fn shared_options(args: &SlurmArgs) -> String {
    let mut s = String::new();
    if let Some(p) = &args.partition {
        let _ = writeln!(s, "#SBATCH --partition={p}");
    }
    if let Some(t) = &args.time {
        let _ = writeln!(s, "#SBATCH --time={t}");
    }
    for o in &args.sbatch {
        let _ = writeln!(s, "#SBATCH {o}");
    }
    s
}

fn render_script(farm: &Farm, args: &SlurmArgs, scene: &Path, yubin: &Path) -> String {
    let n = farm.parts;
    let dir = farm.dir.display().to_string();
    let mut s = String::from("#!/bin/bash\n");
    let _ = writeln!(
        s,
        "# yubin farm: {} as {n} part{} per image, one array task each{}.\n\
         # Written by `yubin farm slurm`; submitted by submit.sh.",
        scene.display(),
        if n > 1 { "s" } else { "" },
        match farm.frames {
            Some((a, b)) => format!(" (frames {a}-{b}: task = (frame - {a}) * {n} + part)"),
            None => String::new(),
        }
    );
    let _ = writeln!(s, "#SBATCH --job-name=yubin-render");
    let _ = writeln!(s, "#SBATCH --array=0-{}", farm.tasks() - 1);
    let _ = writeln!(s, "#SBATCH --cpus-per-task={}", args.cpus_per_task);
    let _ = writeln!(s, "#SBATCH --output={dir}/logs/task_%a.log");
    let _ = writeln!(s, "#SBATCH --open-mode=append");
    let _ = writeln!(s, "#SBATCH --requeue");
    s += &shared_options(args);
    s += "# Pre-empted or cancelled, a task gets SIGTERM: yubin saves its part's\n\
          # state (PART.exr.state) and exits; run again (requeued, or yubin farm\n\
          # resubmit), the same command continues from it.\n\
          set -euo pipefail\n";
    let _ = writeln!(s, "dir={dir}");
    let _ = writeln!(s, "part=$((SLURM_ARRAY_TASK_ID % {n}))");
    let (frame_option, out) = match farm.frames {
        Some((a, _)) => {
            let _ = writeln!(s, "frame=$(({a} + SLURM_ARRAY_TASK_ID / {n}))");
            (
                " --frames \"$frame\"".to_string(),
                "$dir/parts/frame_####.part_$part.exr".to_string(),
            )
        }
        None => (String::new(), "$dir/parts/part_$part.exr".to_string()),
    };
    let render: Vec<String> = args.render.iter().map(|a| quote(a)).collect();
    let _ = writeln!(
        s,
        "exec {} render {} --part \"$part/{n}\"{frame_option} \\\n    --threads \"${{SLURM_CPUS_PER_TASK:-1}}\" --quiet -o \"{out}\"{}",
        quote(&yubin.display().to_string()),
        quote(&scene.display().to_string()),
        if render.is_empty() {
            String::new()
        } else {
            format!(" \\\n    {}", render.join(" "))
        }
    );
    s
}

fn merge_script(farm: &Farm, args: &SlurmArgs, yubin: &Path) -> String {
    let dir = farm.dir.display().to_string();
    let last = farm.parts - 1;
    let parts = if farm.parts > 1 {
        format!("{{0..{last}}}")
    } else {
        "0".to_string()
    };
    let yubin = quote(&yubin.display().to_string());
    let mut s = String::from("#!/bin/bash\n");
    s += "# yubin farm: merges the parts into the image(s), once every task of the\n\
          # render array has succeeded (submit.sh: --dependency=afterok).\n";
    let _ = writeln!(s, "#SBATCH --job-name=yubin-merge");
    // Writing a compressed EXR is parallel: as many cores as a part.
    let _ = writeln!(s, "#SBATCH --cpus-per-task={}", args.cpus_per_task);
    let _ = writeln!(s, "#SBATCH --output={dir}/logs/merge.log");
    let _ = writeln!(s, "#SBATCH --open-mode=append");
    s += &shared_options(args);
    s += "set -euo pipefail\n";
    let _ = writeln!(s, "cd {dir}");
    match farm.frames {
        Some((a, b)) => {
            let image = numbered(&farm.image, "$f");
            let _ = writeln!(
                s,
                "for frame in $(seq {a} {b}); do\n    f=$(printf %04d \"$frame\")\n    {yubin} merge parts/frame_$f.part_{parts}.exr -o \"{image}\"\ndone"
            );
        }
        None => {
            let _ = writeln!(
                s,
                "{yubin} merge parts/part_{parts}.exr -o {}",
                quote(&farm.image)
            );
        }
    }
    s
}

/// submit.sh: what `--submit` does.
const SUBMIT: &str = r#"#!/bin/bash
# yubin farm: submits the render array and the merge, which runs once every
# task has succeeded (and is cancelled if one fails); the ids go to ./jobs.
set -euo pipefail
cd "$(dirname "$0")"
render=$(sbatch --parsable render.sbatch)
render=${render%%;*}
merge=$(sbatch --parsable --dependency="afterok:$render" --kill-on-invalid-dep=yes merge.sbatch)
merge=${merge%%;*}
echo "$render $merge" > jobs
echo "submitted: render job $render, merge job $merge"
"#;

/// Runs sbatch with `args`, returning the job id.
fn sbatch(dir: &Path, args: &[String]) -> Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(args)
        .current_dir(dir)
        .output()
        .context("cannot run sbatch (is Slurm's client installed and on the PATH?)")?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let id = text
        .trim()
        .split(';')
        .next()
        .unwrap_or_default()
        .to_string();
    if id.is_empty() {
        bail!("sbatch {} printed no job id", args.join(" "));
    }
    Ok(id)
}

/// Submits the render array (only `tasks`, when given) and the merge
/// after it (and after `also_after`, the tasks of an earlier array still
/// queued); records and returns the two ids.
fn submit(farm: &Farm, tasks: Option<&str>, also_after: Option<&str>) -> Result<(String, String)> {
    let mut render_args = Vec::new();
    if let Some(t) = tasks {
        render_args.push(format!("--array={t}"));
    }
    render_args.push("render.sbatch".into());
    let render = sbatch(&farm.dir, &render_args)?;
    let mut after = format!("afterok:{render}");
    if let Some(old) = also_after {
        let _ = write!(after, ",afterany:{old}");
    }
    let merge = sbatch(
        &farm.dir,
        &[
            format!("--dependency={after}"),
            "--kill-on-invalid-dep=yes".into(),
            "merge.sbatch".into(),
        ],
    )?;
    std::fs::write(farm.dir.join("jobs"), format!("{render} {merge}\n"))?;
    Ok((render, merge))
}

/// What became of one array task.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum TaskState {
    Done,
    Running,
    Pending,
    /// Stopped with its state saved: samples per pixel done, of all.
    Interrupted(u32, u32),
    /// A part file that is not one, or of another render.
    Damaged(String),
    Missing,
}

impl TaskState {
    fn describe(&self) -> String {
        match self {
            TaskState::Done => "done".into(),
            TaskState::Running => "running".into(),
            TaskState::Pending => "pending".into(),
            TaskState::Interrupted(d, n) => format!("interrupted ({d} of {n} spp saved)"),
            TaskState::Damaged(why) => format!("unusable ({why})"),
            TaskState::Missing => "missing".into(),
        }
    }

    /// Neither done nor queued.
    fn needs_submitting(&self) -> bool {
        !matches!(
            self,
            TaskState::Done | TaskState::Running | TaskState::Pending
        )
    }
}

/// The Slurm states of the tasks of array job `job` still queued or
/// running, by task (empty when squeue is missing or knows none).
fn queued_tasks(job: &str) -> BTreeMap<u64, TaskState> {
    let Ok(out) = Command::new("squeue")
        .args(["-h", "-r", "-j", job, "-o", "%K %T"])
        .output()
    else {
        return BTreeMap::new();
    };
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let (task, state) = l.split_once(' ')?;
            let state = match state.trim() {
                "RUNNING" | "COMPLETING" | "CONFIGURING" => TaskState::Running,
                "PENDING" | "REQUEUED" | "SUSPENDED" => TaskState::Pending,
                _ => return None,
            };
            Some((task.parse().ok()?, state))
        })
        .collect()
}

/// Every task's state, in task order.
fn task_states(farm: &Farm) -> Vec<TaskState> {
    let queued = farm
        .jobs()
        .map(|(render, _)| queued_tasks(&render))
        .unwrap_or_default();
    (0..farm.tasks())
        .map(|task| {
            let (frame, part) = farm.task(task);
            let file = farm.dir.join(farm.part_file(frame, part));
            if let Some(state) = queued.get(&task) {
                return state.clone();
            }
            if file.exists() {
                return match part::read_header(&file) {
                    Ok(h) if h.index == part && h.count == farm.parts && h.done == h.spp => {
                        TaskState::Done
                    }
                    Ok(_) => TaskState::Damaged("of another render".into()),
                    Err(e) => TaskState::Damaged(format!("{e:#}")),
                };
            }
            let state = PathBuf::from(format!("{}.state", file.display()));
            match checkpoint::read(&state) {
                Ok((saved, s)) => {
                    let spp = saved
                        .iter()
                        .find(|(k, _)| k == "spp")
                        .and_then(|(_, v)| v.parse().ok())
                        .unwrap_or(0);
                    TaskState::Interrupted(s.done, spp)
                }
                Err(_) => TaskState::Missing,
            }
        })
        .collect()
}

/// Task numbers as Slurm's --array takes them (`1,4-6`).
fn ranges(tasks: &[u64]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < tasks.len() {
        let mut j = i;
        while j + 1 < tasks.len() && tasks[j + 1] == tasks[j] + 1 {
            j += 1;
        }
        out.push(if i == j {
            tasks[i].to_string()
        } else {
            format!("{}-{}", tasks[i], tasks[j])
        });
        i = j + 1;
    }
    out.join(",")
}

fn status(dir: &Path) -> Result<()> {
    let farm = Farm::read(dir)?;
    let states = task_states(&farm);
    let jobs = farm
        .jobs()
        .map(|(r, m)| format!(", render job {r}, merge job {m}"))
        .unwrap_or_else(|| ", not submitted".into());
    println!(
        "{}: {} part{} per image, {} task{}{jobs}",
        dir.display(),
        farm.parts,
        if farm.parts > 1 { "s" } else { "" },
        farm.tasks(),
        if farm.tasks() > 1 { "s" } else { "" },
    );
    for (place, frame) in farm.frames().into_iter().enumerate() {
        let first = place as u64 * u64::from(farm.parts);
        let image = farm.image_file(frame);
        let merged = if dir.join(&image).exists() {
            "merged"
        } else {
            "not merged"
        };
        let name = frame
            .map(|f| format!("frame {f}"))
            .unwrap_or_else(|| "image".into());
        println!("{name} ({image}, {merged}):");
        for part in 0..farm.parts {
            let task = first + u64::from(part);
            println!(
                "  part {part} (task {task}): {}",
                states[task as usize].describe()
            );
        }
    }
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for s in &states {
        let key = match s {
            TaskState::Interrupted(..) => "interrupted".to_string(),
            TaskState::Damaged(_) => "unusable".to_string(),
            other => other.describe(),
        };
        *counts.entry(key).or_default() += 1;
    }
    let summary: Vec<String> = counts.iter().map(|(k, n)| format!("{n} {k}")).collect();
    println!("{}", summary.join(", "));
    if states.iter().any(TaskState::needs_submitting) {
        println!(
            "to render what is missing: yubin farm resubmit {}",
            quote(&dir.display().to_string())
        );
    }
    Ok(())
}

fn resubmit(dir: &Path, dry_run: bool) -> Result<()> {
    let farm = Farm::read(dir)?;
    let dir = std::fs::canonicalize(dir)?;
    let farm = Farm { dir, ..farm };
    let states = task_states(&farm);
    let missing: Vec<u64> = (0..farm.tasks())
        .filter(|&t| states[t as usize].needs_submitting())
        .collect();
    let queued = states
        .iter()
        .any(|s| matches!(s, TaskState::Running | TaskState::Pending));
    let unmerged = farm
        .frames()
        .into_iter()
        .any(|f| !farm.dir.join(farm.image_file(f)).exists());
    if missing.is_empty() && !unmerged {
        println!("{}: every part is done and merged", farm.dir.display());
        return Ok(());
    }
    if missing.is_empty() {
        if queued {
            println!("nothing to resubmit: the remaining parts are queued, and the merge job follows them");
            return Ok(());
        }
        // Every part is done but not merged (the merge failed, or was
        // cancelled): the merge alone.
        if dry_run {
            println!("sbatch merge.sbatch");
            return Ok(());
        }
        let merge = sbatch(&farm.dir, &["merge.sbatch".into()])?;
        println!("submitted: merge job {merge}");
        return Ok(());
    }
    let tasks = ranges(&missing);
    // A merge must also wait for tasks of the earlier array still queued.
    let old = farm.jobs().map(|(r, _)| r).filter(|_| queued);
    if dry_run {
        let after = old
            .as_deref()
            .map(|o| format!(",afterany:{o}"))
            .unwrap_or_default();
        println!("sbatch --array={tasks} render.sbatch");
        println!(
            "sbatch --dependency=afterok:RENDER{after} --kill-on-invalid-dep=yes merge.sbatch"
        );
        return Ok(());
    }
    let (render, merge) = submit(&farm, Some(&tasks), old.as_deref())?;
    println!("submitted: render job {render} (tasks {tasks}), merge job {merge}");
    Ok(())
}
