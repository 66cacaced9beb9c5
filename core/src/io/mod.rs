//! File plumbing shared by every stage: atomic writes, numpy archives and the output-path guard.

pub mod atomic;
pub mod npz;
pub mod output_path;

pub use atomic::{write_atomic, write_bytes_atomic};
pub use output_path::Inputs;
