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
    #[error("invalid input: {0}")]
    Invalid(String),

    /// A request that would need more memory than the configured limit.
    /// Raised *before* anything is allocated.
    #[error("memory limit exceeded: {what} needs {needed} bytes, limit is {limit} bytes")]
    Limits {
        /// What was about to be allocated.
        what: String,
        /// Bytes the allocation would take.
        needed: u128,
        /// The limit in force.
        limit: u64,
    },

    /// A valid request that voxkit does not support.
    #[error("not supported: {0}")]
    Unsupported(String),

    /// An I/O failure, with the path it concerned.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// Result alias used across the crate.
pub type Result<T, E = VoxkitError> = std::result::Result<T, E>;

impl VoxkitError {
    /// Shorthand for [`VoxkitError::Invalid`].
    pub fn invalid(msg: impl Into<String>) -> Self {
        VoxkitError::Invalid(msg.into())
    }
}
