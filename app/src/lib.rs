//! `avatar-studio` as a library: the studio (egui), so that tests can drive it.

pub mod cache;
pub mod error;
pub mod studio;

pub use error::StudioError;
