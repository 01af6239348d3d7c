//! The crate's error type, split by responsibility (as `image` and `exr` do):
//! bad input, limits, unsupported requests and I/O.

use std::path::PathBuf;

/// Everything that can go wrong in voxkit. Bad input never panics: it becomes
/// one of these, and the command line turns it into one line on stderr and a
/// non-zero exit code.
#[derive(Debug, thiserror::Error)]
pub enum VoxkitError {
    /// Input that is malformed or outside the documented range
    /// (a NaN coordinate, a coordinate beyond ±2^30, a collinear triangle where
    /// one is not allowed, ...).
    #[error("invalid input: {}", printable(.0))]
    Invalid(String),

    /// A request that would need more memory than the configured limit.
    /// Raised *before* anything is allocated.
    #[error(
        "memory limit exceeded: {} needs {needed} bytes, limit is {limit} bytes",
        printable(.what)
    )]
    Limits {
        /// What was about to be allocated.
        what: String,
        /// Bytes the allocation would take.
        needed: u128,
        /// The limit in force.
        limit: u64,
    },

    /// A valid request that voxkit does not support.
    #[error("not supported: {}", printable(.0))]
    Unsupported(String),

    /// An I/O failure, with the path it concerned.
    #[error("{}: {source}", printable(&path.display().to_string()))]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// A vector as a message shows it, `[x, y, z]`: each number as written
/// (`0.5`, `-3`), or in exponent form beyond `1e-5 ≤ |x| < 1e16`, so that a
/// spacing of 1e300 reads as `1e300` rather than as three hundred digits.
///
/// ```
/// use glam::DVec3;
/// assert_eq!(voxkit::error::shown(DVec3::new(0.5, -3.0, 0.0)), "[0.5, -3, 0]");
/// assert_eq!(voxkit::error::shown(DVec3::new(1e300, 2.5e-30, f64::NAN)), "[1e300, 2.5e-30, NaN]");
/// ```
pub fn shown(v: glam::DVec3) -> String {
    let number = |x: f64| {
        if x == 0.0 || !x.is_finite() || (1e-5..1e16).contains(&x.abs()) {
            format!("{x}")
        } else {
            format!("{x:e}")
        }
    };
    format!("[{}, {}, {}]", number(v.x), number(v.y), number(v.z))
}

/// `text` with its control characters escaped (`\r`, `\t`, `\0`,
/// `\u{1b}`…): messages quote what a file says (a header line, a name), and a
/// stray carriage return or NUL there must not break the message's one line
/// or the terminal showing it.
///
/// ```
/// assert_eq!(voxkit::error::printable("line `ply\r\0`"), "line `ply\\r\\0`");
/// ```
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return text.into();
    }
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_debug().to_string()
            } else {
                c.to_string()
            }
        })
        .collect::<String>()
        .into()
}

/// Result alias used across the crate.
pub type Result<T, E = VoxkitError> = std::result::Result<T, E>;

/// A copy of the error: an I/O error keeps its kind and message (what
/// `std::io::Error` lets a copy keep).
impl Clone for VoxkitError {
    fn clone(&self) -> Self {
        match self {
            VoxkitError::Invalid(s) => VoxkitError::Invalid(s.clone()),
            VoxkitError::Limits {
                what,
                needed,
                limit,
            } => VoxkitError::Limits {
                what: what.clone(),
                needed: *needed,
                limit: *limit,
            },
            VoxkitError::Unsupported(s) => VoxkitError::Unsupported(s.clone()),
            VoxkitError::Io { path, source } => VoxkitError::Io {
                path: path.clone(),
                source: std::io::Error::new(source.kind(), source.to_string()),
            },
        }
    }
}

impl VoxkitError {
    /// Shorthand for [`VoxkitError::Invalid`].
    pub fn invalid(msg: impl Into<String>) -> Self {
        VoxkitError::Invalid(msg.into())
    }
}
