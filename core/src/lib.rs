//! Avatar Studio core: the science and the file formats, no GUI.
//!
//! Data flows one way through the stages, one module each:
//! capture -> canonical points -> avatar model -> meshes -> viewport or export.

pub mod body;
pub mod error;
pub mod io;
pub mod mesh;

pub use error::{Error, Result};
