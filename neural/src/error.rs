//! The neural crate's error. Reading and checking files (weights, the meta-model, avatars,
//! captures) fails with core's error, which names the file and the problem; what only this
//! crate can get wrong has a variant of its own.

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file or an argument is wrong (core's error: it names the file where one is involved).
    #[error(transparent)]
    Core(#[from] avatar_core::Error),
    /// `--device` names a device this build does not have.
    #[error("--device {name:?}: {reason}")]
    Device { name: String, reason: String },
    /// An avatar file of a kind this build cannot load (said as core says a file's problem).
    #[error("{path}: {kind:?} is not an avatar this build can load ({known})")]
    AvatarKind { path: PathBuf, kind: String, known: String },
    /// An option out of range (`config::Check`): which option, its value and its bound.
    #[error("option {option} = {value} is out of range: it must be {bound}")]
    Option { option: &'static str, value: String, bound: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub fn file(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        avatar_core::Error::file(path, message).into()
    }
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        avatar_core::Error::io(path, source).into()
    }
    pub fn invalid(message: impl Into<String>) -> Self {
        avatar_core::Error::invalid(message).into()
    }
    pub fn option(
        option: &'static str,
        value: &dyn std::fmt::Display,
        bound: impl Into<String>,
    ) -> Self {
        Error::Option { option, value: value.to_string(), bound: bound.into() }
    }
    /// Re-attribute an in-memory validation error to the file it came from.
    pub fn in_file(self, path: impl AsRef<Path>) -> Self {
        match self {
            Error::Core(e) => Error::Core(e.in_file(path)),
            e @ Error::Option { .. } => avatar_core::Error::file(path, e.to_string()).into(),
            other => other,
        }
    }
}

/// For core's traits that a neural type implements (`eval::Predictor`).
impl From<Error> for avatar_core::Error {
    fn from(e: Error) -> Self {
        match e {
            Error::Core(e) => e,
            Error::AvatarKind { path, kind, known } => avatar_core::Error::file(
                path,
                format!("{kind:?} is not an avatar this build can load ({known})"),
            ),
            other => avatar_core::Error::invalid(other.to_string()),
        }
    }
}
