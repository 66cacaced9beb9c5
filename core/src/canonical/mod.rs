//! Canonicalization: the diffused skinning field, inverse skinning of depth points by root
//! finding with the 2 cm filter, forward skinning of canonical meshes, and the [-1, 1]^3
//! normalisation. See docs/canonicalization.md.

pub mod body_wrap;
pub mod cache;
pub mod canonicalize;
pub mod field;
pub mod fold_guard;
pub mod garment_sheet;
pub mod garment_skinning;
pub mod normalise;
pub mod offset_smoothing;
pub mod pose_displacement;
pub mod root_finding;
pub mod sheets;
pub mod shell;

pub use body_wrap::{BodyWrap, SurfaceChoice, WrapOptions, Wrapped};
pub use cache::{FieldCache, cached_field};
pub use canonicalize::{
    CanonicalFrame, NEAREST_TIE, REPROJECTION_THRESHOLD, RootPick, canonicalize_points,
    canonicalize_points_from, choose_by_agreement, choose_nearest, forward_skin_mesh,
};
pub use field::{FIELD_CELLS, FieldOptions, SkinningField};
pub use garment_sheet::{GarmentSheet, SheetGridOptions};
pub use garment_skinning::{
    GarmentSkinner, GarmentSkinning, field_weights, forward_skin_with_weights, garment_weights,
    inpaint_loose_weights,
};
pub use normalise::Normalisation;
pub use offset_smoothing::{OffsetSmoothing, SurfaceSmoother, smooth_body_offsets};
pub use pose_displacement::{DisplacementLimit, bound_moves};
pub use root_finding::{Root, RootOptions, find_root_from, find_roots, forward_point, start_bones};
pub use sheets::{SheetOptions, open_inner_walls};
pub use shell::{ShellOptions, shell_samples};

use crate::body::BodyModel;
use crate::capture::CaptureFrame;
use crate::error::Result;
use crate::mesh::bvh::Bvh;
use glam::Vec3;
use std::path::Path;

/// Everything needed to canonicalize the frames of one subject: the body, its shape and the
/// field built (or loaded from the cache) for that shape.
pub struct Canonicalizer<'a> {
    pub body: &'a BodyModel,
    pub betas: Vec<f32>,
    pub rest: Vec<Vec3>,
    pub field: SkinningField,
    pub normalisation: Normalisation,
    pub options: RootOptions,
    /// Set when a cache file was bad and rebuilt.
    pub cache_warning: Option<String>,
    /// The rest body's surface, to choose among several roots.
    rest_surface: Bvh,
}

impl<'a> Canonicalizer<'a> {
    pub fn new(
        body: &'a BodyModel,
        betas: &[f32],
        field_options: &FieldOptions,
        cache_dir: Option<&Path>,
    ) -> Result<Self> {
        field_options.validate()?;
        crate::body::check_betas(betas)?;
        let rest = body.shaped_vertices(betas);
        let (field, cache_warning) = cached_field(body, &rest, field_options, cache_dir)?;
        let normalisation = Normalisation::from_body(&rest);
        let rest_surface = Bvh::build(&body.mesh(rest.clone()));
        Ok(Canonicalizer {
            body,
            betas: betas.to_vec(),
            rest,
            field,
            normalisation,
            options: RootOptions::default(),
            cache_warning,
            rest_surface,
        })
    }

    /// Canonicalize one capture frame's points and normals.
    pub fn frame(&self, frame: &CaptureFrame) -> CanonicalFrame {
        self.posed_points(&frame.params, &frame.points, &frame.normals)
    }

    /// Canonicalize oriented points posed by `params` (world space, metres): a capture
    /// frame's, or points sampled on a clothed scan fitted with `params`.
    pub fn posed_points(
        &self,
        params: &crate::body::BodyParams,
        points: &[Vec3],
        normals: &[Vec3],
    ) -> CanonicalFrame {
        let posed = self.body.pose(params);
        let distance = |x: Vec3, cap: f32| self.distance_to_body(x, cap);
        canonicalize_points_from(
            &self.field,
            &posed.bones,
            &posed.vertices,
            &self.body.weights,
            points,
            normals,
            &[],
            &self.options,
            RootPick::Nearest(&distance),
        )
    }

    /// The distance from the rest body's surface by which a point's roots are chosen: of
    /// several, the nearest (PINA keeps the root of smallest SDF; before the avatar exists, the
    /// body's is the SDF there is). Where a squat or a bend presses the thigh to the belly, the
    /// other roots lie tens of centimetres off the body, and a fit grows sheets through them.
    /// Infinity when the point is not below `cap` from the body (a shorter search).
    fn distance_to_body(&self, x: Vec3, cap: f32) -> f32 {
        self.rest_surface.closest_point_within(x, cap).map_or(f32::INFINITY, |h| h.distance)
    }

    /// Canonical positions of free-space samples of one frame (posed, world space): the
    /// samples whose root reprojects within the 2 cm filter.
    pub fn free_space(&self, frame: &CaptureFrame, samples: &[Vec3]) -> Vec<Vec3> {
        let posed = self.body.pose(&frame.params);
        let no_normals = vec![Vec3::Z; samples.len()];
        let distance = |x: Vec3, cap: f32| self.distance_to_body(x, cap);
        canonicalize_points_from(
            &self.field,
            &posed.bones,
            &posed.vertices,
            &self.body.weights,
            samples,
            &no_normals,
            &[],
            &self.options,
            RootPick::Nearest(&distance),
        )
        .points
    }
}
