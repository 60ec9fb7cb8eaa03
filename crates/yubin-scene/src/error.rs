//! Errors of the scene front ends. Every error a user can cause names the
//! file and, where there is one, the line.

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

/// A place in a scene file: the file and a 1-based line number (0 when the
/// error concerns the whole file).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    /// The file, as given or resolved.
    pub file: Arc<PathBuf>,
    /// 1-based line, or 0 when unknown.
    pub line: u32,
}

impl Location {
    /// A location in `file` at `line` (1-based; 0 for "the whole file").
    pub fn new(file: Arc<PathBuf>, line: u32) -> Self {
        Self { file, line }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "{}:{}", self.file.display(), self.line)
        } else {
            write!(f, "{}", self.file.display())
        }
    }
}

/// Anything that can go wrong while reading a scene or its assets.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A problem at a known place in a file: `scene.xml:42: message`.
    #[error("{loc}: {msg}")]
    At {
        /// Where.
        loc: Location,
        /// What, in words a user can act on.
        msg: String,
    },
    /// A file that could not be found; lists every path that was tried.
    #[error("{}file not found: \"{name}\" (searched: {})", .from.as_ref().map(|l| format!("{l}: ")).unwrap_or_default(), .searched.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))]
    NotFound {
        /// The name as written in the scene.
        name: String,
        /// Every candidate path that was tried.
        searched: Vec<PathBuf>,
        /// The reference that asked for it.
        from: Option<Location>,
    },
    /// A plugin's parameter error; the message names the place.
    #[error("{0}")]
    Plugin(String),
    /// An I/O error on a file.
    // The I/O error is part of the message, not a separate cause, so that
    // printing the error chain doesn't say it twice.
    #[error("{}: {error}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// A problem with a file as a whole (an image that cannot be decoded, say).
    #[error("{}: {msg}", .path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        msg: String,
    },
}

impl SceneError {
    /// An error at `loc`.
    pub fn at(loc: &Location, msg: impl Into<String>) -> Self {
        Self::At {
            loc: loc.clone(),
            msg: msg.into(),
        }
    }

    /// An error about a whole file.
    pub fn file(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Self::File {
            path: path.into(),
            msg: msg.into(),
        }
    }
}

impl From<yubin_core::params::ParamError> for SceneError {
    fn from(e: yubin_core::params::ParamError) -> Self {
        SceneError::Plugin(e.0)
    }
}
