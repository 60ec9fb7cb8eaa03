//! SIGINT and SIGTERM as a request to stop and keep the work: a render
//! that gets one finishes nothing more, writes the image of the samples
//! it has (and its checkpoint, when it keeps one) and exits with 130 or
//! 143, as a shell expects of a process ended by those signals. A second
//! signal of the same kind ends the process at once, for a user who will
//! not wait for the write.

use anyhow::{Context, Result};
use signal_hook::consts::{SIGINT, SIGTERM};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// The signals watched, as flags.
#[derive(Debug)]
pub struct Interrupt {
    /// Set by either signal: the render stops.
    stop: Arc<AtomicBool>,
    /// Per signal, whether it came, and the exit code it asks for.
    signals: [(Arc<AtomicBool>, i32); 2],
}

impl Interrupt {
    /// The process's watch on SIGINT and SIGTERM, set up on first use.
    pub fn watch() -> Result<&'static Interrupt> {
        static WATCH: OnceLock<Interrupt> = OnceLock::new();
        if let Some(w) = WATCH.get() {
            return Ok(w);
        }
        let stop = Arc::new(AtomicBool::new(false));
        let mut signals = Vec::new();
        for (signal, name, code) in [(SIGINT, "SIGINT", 130), (SIGTERM, "SIGTERM", 143)] {
            let came = Arc::new(AtomicBool::new(false));
            // Registered first, so it sees the flag as the previous signal
            // left it: the second signal exits.
            signal_hook::flag::register_conditional_shutdown(signal, code, Arc::clone(&came))
                .and_then(|_| signal_hook::flag::register(signal, Arc::clone(&came)))
                .and_then(|_| signal_hook::flag::register(signal, Arc::clone(&stop)))
                .with_context(|| format!("cannot watch for {name}"))?;
            signals.push((came, code));
        }
        let [int, term]: [(Arc<AtomicBool>, i32); 2] = signals.try_into().expect("two signals");
        Ok(WATCH.get_or_init(|| Interrupt {
            stop,
            signals: [int, term],
        }))
    }

    /// The flag a render polls.
    pub fn stop(&self) -> &AtomicBool {
        &self.stop
    }

    /// The exit code of the signal that came, if one did.
    pub fn exit_code(&self) -> Option<i32> {
        self.signals
            .iter()
            .find(|(came, _)| came.load(Ordering::Relaxed))
            .map(|(_, code)| *code)
    }
}
