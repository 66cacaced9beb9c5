//! File plumbing shared by every stage: atomic writes and numpy archives.

pub mod atomic;
pub mod npz;

pub use atomic::{write_atomic, write_bytes_atomic};
