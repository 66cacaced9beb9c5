//! The app crate's error. Reading and writing files fails with core's or the neural crate's
//! error, which names the file and the problem; the studio's own checks have variants of their
//! own. `anyhow` is used only by the command line (app/src/cli, main.rs) and where the studio
//! turns an error into a message in its status bar.

use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Debug, thiserror::Error)]
pub enum StudioError {
    /// A file or an argument is wrong (core's error: it names the file where one is involved).
    #[error(transparent)]
    Core(#[from] avatar_core::Error),
    /// The avatar crate's error (avatar files, fitting).
    #[error(transparent)]
    Neural(#[from] avatar_neural::Error),
    /// A file the studio reads itself (a project, a scan, a screenshot) is wrong or missing.
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    /// A request the studio cannot carry out (no file involved): an empty screenshot, a fit
    /// setting of 0, a cancelled bake, no GPU adapter.
    #[error("{0}")]
    Invalid(String),
    /// A background task of the studio failed or panicked.
    #[error(transparent)]
    Task(#[from] TaskError),
    /// What the studio was doing when `cause` happened ("Could not mesh the avatar: …"). The
    /// cause is part of the message, not a `source`, so error chains print it once.
    #[error("{context}: {cause}")]
    Context { context: String, cause: Box<StudioError> },
}

pub type Result<T, E = StudioError> = std::result::Result<T, E>;

/// Why a background task (`studio::tasks`) produced no result.
#[derive(Debug, Clone, thiserror::Error)]
pub enum TaskError {
    /// The work returned an error (its message says what was being done, then the cause).
    #[error("{0}")]
    Failed(Arc<StudioError>),
    /// The work panicked: a bug, reported instead of taking the studio down.
    #[error("the {0} stopped on an internal error")]
    Panicked(&'static str),
}

impl From<StudioError> for TaskError {
    fn from(e: StudioError) -> Self {
        TaskError::Failed(Arc::new(e))
    }
}

impl StudioError {
    pub fn file(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        StudioError::File { path: path.as_ref().to_path_buf(), message: message.into() }
    }
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        avatar_core::Error::io(path, source).into()
    }
    pub fn invalid(message: impl Into<String>) -> Self {
        StudioError::Invalid(message.into())
    }
    /// This error, said as the cause of what the studio was doing.
    pub fn context(self, context: impl Into<String>) -> Self {
        StudioError::Context { context: context.into(), cause: Box::new(self) }
    }
}

/// `.context(…)` on a result whose error converts into [`StudioError`].
pub trait Context<T> {
    fn context(self, context: impl Into<String>) -> Result<T>;
}

impl<T, E: Into<StudioError>> Context<T> for std::result::Result<T, E> {
    fn context(self, context: impl Into<String>) -> Result<T> {
        self.map_err(|e| e.into().context(context))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_file_and_keep_the_cause_once() {
        let e = StudioError::from(avatar_core::Error::file("a/x.avatar", "bad header"))
            .context("Could not open the avatar a/x.avatar");
        assert_eq!(e.to_string(), "Could not open the avatar a/x.avatar: a/x.avatar: bad header");
        assert!(std::error::Error::source(&e).is_none());
        let r: Result<()> =
            Err(avatar_neural::Error::invalid("no frames")).context("Could not mesh the avatar");
        assert_eq!(r.unwrap_err().to_string(), "Could not mesh the avatar: no frames");
        assert_eq!(
            StudioError::file("p.studio.json", "not a studio project").to_string(),
            "p.studio.json: not a studio project"
        );
    }
}
