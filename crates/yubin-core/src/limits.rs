//! Limits on what a scene may ask for, checked before anything is
//! allocated, so that a file that asks for too much (a 100000 × 100000
//! film, a texture whose header claims 10⁹ × 10⁹ texels) gets a clear
//! error naming the limit instead of an aborted process. Each limit has a
//! name, which `yubin render --limit NAME=N` raises (or lowers) for the
//! whole process. What a file cannot hold (a PLY header claiming more
//! faces than its bytes can encode) is refused by the loaders whatever
//! the limits.

use std::sync::atomic::{AtomicU64, Ordering};

/// One limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limit {
    /// Pixels a render's film (its crop window) may have.
    FilmPixels,
    /// Texels an image file (texture, environment map) may have.
    TexturePixels,
    /// Cells (times channels) a volume grid may have.
    GridCells,
    /// Files an `<include>` chain may nest.
    IncludeDepth,
}

/// Every limit, in the order [`Limit::index`] numbers them.
pub const ALL: [Limit; 4] = [
    Limit::FilmPixels,
    Limit::TexturePixels,
    Limit::GridCells,
    Limit::IncludeDepth,
];

/// The defaults: a 16384 × 16384 film (about 12 GiB of render buffers),
/// 2³⁰ texels (16 GiB as RGBA float), 2³² grid values (16 GiB), 64
/// nested includes.
const DEFAULTS: [u64; 4] = [1 << 28, 1 << 30, 1 << 32, 64];

static VALUES: [AtomicU64; 4] = [
    AtomicU64::new(DEFAULTS[0]),
    AtomicU64::new(DEFAULTS[1]),
    AtomicU64::new(DEFAULTS[2]),
    AtomicU64::new(DEFAULTS[3]),
];

impl Limit {
    fn index(self) -> usize {
        self as usize
    }

    /// Its name, as `--limit` takes it.
    pub fn name(self) -> &'static str {
        match self {
            Limit::FilmPixels => "film-pixels",
            Limit::TexturePixels => "texture-pixels",
            Limit::GridCells => "grid-cells",
            Limit::IncludeDepth => "include-depth",
        }
    }

    /// The limit called `name`.
    pub fn named(name: &str) -> Option<Limit> {
        ALL.into_iter().find(|l| l.name() == name)
    }

    /// Its value now.
    pub fn get(self) -> u64 {
        VALUES[self.index()].load(Ordering::Relaxed)
    }

    /// Sets it for the whole process.
    pub fn set(self, value: u64) {
        VALUES[self.index()].store(value, Ordering::Relaxed);
    }

    /// Its default value.
    pub fn default_value(self) -> u64 {
        DEFAULTS[self.index()]
    }

    /// `Ok` when `amount` of it (what the file asks for, described by
    /// `what`) is within the limit; else the message that says so.
    pub fn check(self, amount: u64, what: impl FnOnce() -> String) -> Result<(), String> {
        let limit = self.get();
        if amount <= limit {
            return Ok(());
        }
        Err(format!(
            "{} is more than the limit of {limit} {}; raise it with --limit {}=N",
            what(),
            self.unit(),
            self.name()
        ))
    }

    fn unit(self) -> &'static str {
        match self {
            Limit::FilmPixels => "pixels",
            Limit::TexturePixels => "texels",
            Limit::GridCells => "grid values",
            Limit::IncludeDepth => "nested includes",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_checks_say_the_limit() {
        for l in ALL {
            assert_eq!(Limit::named(l.name()), Some(l));
            assert_eq!(l.get(), l.default_value());
        }
        let e = Limit::FilmPixels
            .check(1 << 29, || "a film of 2^29 pixels".into())
            .unwrap_err();
        assert!(
            e.contains("268435456") && e.contains("--limit film-pixels=N"),
            "{e}"
        );
        assert!(Limit::FilmPixels.check(1 << 28, String::new).is_ok());
    }
}
