//! Waiting for a quiet machine, as raybench's `--wait-quiet` does: the
//! development machine is shared, so before each measurement we wait
//! until other processes use less than a given fraction of all cores over
//! one second, and afterwards report how much they used during it.
//!
//! "Other processes" is the machine's busy time (`/proc/stat`) minus this
//! process's user and system time (`/proc/self/stat`), both in clock ticks.

use std::time::{Duration, Instant};

/// Clock ticks per second of `/proc` accounting (`USER_HZ`, 100 on Linux).
const TICKS_PER_SECOND: f64 = 100.0;

/// Busy ticks of the whole machine and of this process.
#[derive(Clone, Copy, Debug)]
pub struct CpuSnapshot {
    machine: u64,
    own: u64,
    at: Instant,
}

impl CpuSnapshot {
    /// Now (zeros where `/proc` can't be read).
    pub fn take() -> Self {
        let stat = std::fs::read_to_string("/proc/stat").unwrap_or_default();
        // cpu  user nice system idle iowait irq softirq steal ...
        let machine = stat
            .lines()
            .next()
            .map(|line| {
                let f: Vec<u64> = line
                    .split_whitespace()
                    .skip(1)
                    .filter_map(|v| v.parse().ok())
                    .collect();
                [0, 1, 2, 5, 6, 7].iter().filter_map(|&i| f.get(i)).sum()
            })
            .unwrap_or(0);
        let own_stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
        // Fields after the ")" closing the command name: state is field 3,
        // utime and stime are fields 14 and 15.
        let own = own_stat
            .rsplit(')')
            .next()
            .map(|rest| {
                let f: Vec<&str> = rest.split_whitespace().collect();
                [11, 12]
                    .iter()
                    .filter_map(|&i| f.get(i)?.parse::<u64>().ok())
                    .sum()
            })
            .unwrap_or(0);
        Self {
            machine,
            own,
            at: Instant::now(),
        }
    }

    /// Fraction of all cores that other processes used since `self`.
    pub fn foreign_load(&self) -> f64 {
        let now = Self::take();
        let wall = now.at.duration_since(self.at).as_secs_f64().max(1e-3);
        let foreign = now
            .machine
            .saturating_sub(self.machine)
            .saturating_sub(now.own.saturating_sub(self.own));
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
        (foreign as f64 / TICKS_PER_SECOND / (wall * cores)).max(0.0)
    }
}

/// Blocks until other processes use less than `threshold` of the machine
/// over one second, or `give_up` has passed. Returns the time waited
/// beyond the first probe second, and whether it gave up.
pub fn wait_quiet(threshold: f64, give_up: Duration) -> (Duration, bool) {
    let start = Instant::now();
    loop {
        let s = CpuSnapshot::take();
        std::thread::sleep(Duration::from_secs(1));
        if s.foreign_load() < threshold {
            return (
                start.elapsed().saturating_sub(Duration::from_secs(1)),
                false,
            );
        }
        if start.elapsed() > give_up {
            return (start.elapsed(), true);
        }
    }
}
