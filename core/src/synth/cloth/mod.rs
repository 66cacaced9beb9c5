//! Garments that move as cloth: a long skirt and a cape simulated through a motion (they lag,
//! swing, fold and drape over a raised knee), where the other outfits are offset surfaces and
//! rigid panels. The outfits `Outfit::SimSkirt` and `Outfit::SimCape` carry the garment's rest
//! shape in their template (after the body's vertices, as the panels do); `simulate_garment`
//! plays it through a sequence of poses.
//!
//! - `solver`: the position-based solver (stretch, bending, tethers, gravity, damping, body
//!   collision);
//! - `garment`: the cape's rest shape, which vertices hang from the body, the garment's mesh;
//! - `track`: a garment simulated through a clip, the ground truth of the simulated outfits.

pub mod garment;
pub mod solver;
pub mod track;

pub use garment::{garment_mesh, pinned_vertices};
pub use solver::{BodyCollider, Cloth, ClothConfig};
pub use track::{GarmentTrack, simulate_garment, with_garment};
