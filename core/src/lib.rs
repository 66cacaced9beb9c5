//! Avatar Studio core: the science and the file formats, no GUI.
//!
//! Data flows one way through the stages, one module each:
//! capture -> canonical points -> avatar model -> meshes -> viewport or export.
//! `body` (the articulated body) and `motion` (pose sequences) feed every stage; `synth`
//! produces captures with ground truth; `eval` scores meshes against it.

pub mod avatar;
pub mod body;
pub mod canonical;
pub mod capture;
pub mod error;
pub mod eval;
pub mod export;
pub mod io;
pub mod mesh;
pub mod motion;
pub mod own_data;
pub mod synth;

pub use error::{Error, Result};
