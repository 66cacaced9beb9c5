//! A loose avatar fitted to a synthetic dress capture comes out whole where a mesh can be
//! checked without ground truth: its surface has the skirt beside the wrapped body, as one
//! sheet whose only border is its waist and hem, and at held-out poses of another motion no
//! edge of the posed mesh is shared by more than two faces, its faces the same at every pose
//! (docs/integrity.md; `canonical::garment_sheet`, `mesh::topology::drop_non_manifold_faces`).

use avatar_core::body::open_body_ref;
use avatar_core::canonical::FieldCache;
use avatar_core::canonical::SurfaceChoice;
use avatar_core::eval::runner::query;
use avatar_core::mesh::integrity::integrity;
use avatar_core::motion::library_clip;
use avatar_core::synth::{Outfit, SynthJob, generate_capture};
use avatar_neural::avatar::{AnyAvatar, AvatarFit, FitKind, fit_avatar};
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::{HyperFitOptions, Init, MetaModel};

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

#[test]
fn a_posed_dress_avatar_has_loose_pieces_and_no_non_manifold_edge() {
    let dir = tempfile::tempdir().unwrap();
    let mut job = SynthJob::new(1000, Outfit::Dress, library_clip("walk").unwrap());
    job.frames = Some(6);
    generate_capture(dir.path(), open_body_ref(), &job).unwrap();
    let capture = CapturePoints::open(dir.path(), 6, &field_cache()).unwrap();
    let model = MetaModel::shipped();
    let options = HyperFitOptions { steps: 24, ..HyperFitOptions::default() };
    let fit = AvatarFit {
        kind: FitKind::Meta(Init::MetaLearned(&model)),
        options,
        chunk: 0,
        cancel: None,
        trace: None,
    };
    let (AnyAvatar::Meta(avatar), _) = fit_avatar(&capture, &fit, &mut |_| {}).unwrap() else {
        panic!("a meta fit gives a MetaAvatar");
    };
    assert_eq!(avatar.surface_kind(), SurfaceChoice::WrappedWithLoose, "the skirt is loose");
    let betas = capture.frames[0].params.betas.clone();
    let kick = library_clip("kick").unwrap();
    let mut faces = None;
    for frame in kick.frames.iter().step_by(20) {
        let mesh = avatar.posed_mesh(&query(frame, &betas)).unwrap();
        // One rest surface moved to every pose (FITE's explicit template): the same faces,
        // so the same waist and hem, at every pose.
        assert_eq!(*faces.get_or_insert_with(|| mesh.faces.clone()), mesh.faces);
        let whole = integrity(&mesh);
        assert!(whole.boundary_edges > 0, "the hem is an open border: {whole:?}");
        assert_eq!(whole.non_manifold_edges, 0, "{whole:?}");
        // The skirt is one sheet (`canonical::garment_sheet`) beside the wrapped body, its
        // border the waist and the hem: the true dress's are 3.3 m on subject 1001 (before the
        // sheet, such fits had 3-29 pieces and 10-17 m of border).
        assert_eq!(whole.pieces, 2, "the body and the skirt: {whole:?}");
        assert!(whole.boundary_length_m < 6.5, "{whole:?}");
    }
}
