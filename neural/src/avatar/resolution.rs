//! How finely an avatar's surface is meshed: one type, [`MeshResolution`], with its limits and
//! defaults here and nowhere else. Every mesh of an avatar is made at a resolution passed in
//! (`MetaAvatar::canonical_mesh_at`, `posed_mesh_at`); the resolution an avatar carries is what
//! posing and export (`AvatarSource`) mesh it at, `MeshResolution::OUTPUT` unless the caller
//! sets another (`AnyAvatar::set_mesh_resolution`).

use crate::error::{Error, Result};

/// Marching-cubes cells along the longest side of the avatar's cube, from
/// [`MeshResolution::MIN`] to [`MeshResolution::MAX`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MeshResolution(usize);

impl MeshResolution {
    /// Below 16 cells no body survives.
    pub const MIN: usize = 16;
    /// Above 512 one mesh takes minutes.
    pub const MAX: usize = 512;

    /// The meshes users get (`pose`, `export`, the evaluation; the studio meshes at its own
    /// settings). At 128 cells (1.7 cm) the mesh's facets cost the normals: the tight outfits'
    /// NC on clean captures is 0.869 at 128, 0.893 at 192, 0.900 at 256 (docs/decisions.md).
    /// The evaluation of four captures (fits included) takes 97 s at 192 against 71 s at 128.
    pub const OUTPUT: MeshResolution = MeshResolution(192);

    /// The finest grid the loose pieces (a skirt, a coat's tails) are extracted on. Loose cloth
    /// is learned from a few noisy depth frames and its SDF carries flaps and holes a few
    /// millimetres across that a finer grid draws; the coarser one draws the cloth's shape. One
    /// fitted dress per subject, held-out poses (docs/decisions.md): 192 cells 0.841 cm / 10.7 %
    /// spurious, 128 cells 0.765 / 9.0 %, NC 0.830 -> 0.827; 96 cells loses NC (0.800 on
    /// subject 1004). Tight clothing (the wrapped body) does not depend on it.
    pub const LOOSE_MAX: usize = 128;

    /// `cells`, or an error naming the option and the bounds.
    pub fn new(cells: usize) -> Result<Self> {
        if (Self::MIN..=Self::MAX).contains(&cells) {
            Ok(MeshResolution(cells))
        } else {
            Err(Error::option("resolution", &cells, format!("from {} to {}", Self::MIN, Self::MAX)))
        }
    }

    /// `cells` brought within the bounds (a slider's value, a setting from an older file).
    pub fn clamped(cells: usize) -> Self {
        MeshResolution(cells.clamp(Self::MIN, Self::MAX))
    }

    pub const fn cells(self) -> usize {
        self.0
    }

    /// The resolution of an avatar's loose pieces: this, at most [`MeshResolution::LOOSE_MAX`].
    pub fn loose(self) -> usize {
        self.0.min(Self::LOOSE_MAX)
    }
}

impl Default for MeshResolution {
    fn default() -> Self {
        Self::OUTPUT
    }
}

impl std::fmt::Display for MeshResolution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} cells", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolutions_out_of_bounds_are_refused_by_name_and_clamped_on_request() {
        assert_eq!(MeshResolution::new(16).unwrap().cells(), 16);
        assert_eq!(MeshResolution::new(512).unwrap().cells(), 512);
        for bad in [0, 15, 513] {
            let e = MeshResolution::new(bad).unwrap_err().to_string();
            assert!(e.contains("resolution") && e.contains("from 16 to 512"), "{e}");
        }
        assert_eq!(MeshResolution::clamped(8).cells(), 16);
        assert_eq!(MeshResolution::clamped(4096).cells(), 512);
        assert_eq!(MeshResolution::OUTPUT.loose(), 128);
        assert_eq!(MeshResolution::new(96).unwrap().loose(), 96);
    }
}
