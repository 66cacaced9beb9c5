//! One error type for the whole core. Every variant that concerns user data names the file.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file exists but its content is wrong: names the file and the problem.
    #[error("{path}: {message}")]
    InvalidFile { path: PathBuf, message: String },
    /// The operating system refused a read or write.
    /// (The cause is part of the message rather than a `source`, so error chains print it once.)
    #[error("{path}: {cause}")]
    Io { path: PathBuf, cause: std::io::Error },
    /// Bad arguments or inconsistent in-memory data (no file involved).
    #[error("{0}")]
    Invalid(String),
}

impl Error {
    pub fn file(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Error::InvalidFile { path: path.as_ref().to_path_buf(), message: message.into() }
    }
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io { path: path.as_ref().to_path_buf(), cause: source }
    }
    pub fn invalid(message: impl Into<String>) -> Self {
        Error::Invalid(message.into())
    }
    /// Re-attribute an in-memory validation error to the file it came from.
    pub fn in_file(self, path: impl AsRef<Path>) -> Self {
        match self {
            Error::Invalid(message) => Error::file(path, message),
            other => other,
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;
