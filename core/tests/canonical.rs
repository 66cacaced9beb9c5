//! Canonicalization: the diffused field equals the body's weights on the surface, root finding
//! recovers known canonical points under library poses, forward-then-inverse round trips, the
//! normalisation, the cache.

use avatar_core::body::{BodyParams, NUM_JOINTS, open_body_ref};
use avatar_core::canonical::*;
use avatar_core::motion::clip_by_name;
use glam::Vec3;

fn small() -> FieldOptions {
    FieldOptions { cells_along_height: 80, ..FieldOptions::default() }
}

fn canon() -> Canonicalizer<'static> {
    Canonicalizer::new(open_body_ref(), &[], &small(), None).unwrap()
}

#[test]
fn field_equals_body_weights_on_the_surface_and_sums_to_one() {
    let c = canon();
    let body = open_body_ref();
    let mut errs: Vec<f32> = (0..c.rest.len())
        .step_by(7)
        .map(|v| {
            let w = c.field.weights_at(c.rest[v]);
            let s: f32 = w.iter().sum();
            assert!((s - 1.0).abs() < 1e-4, "weights sum {s}");
            assert!(w.iter().all(|&x| (0.0..=1.0 + 1e-6).contains(&x)));
            (0..NUM_JOINTS).map(|j| (w[j] - body.weights[v][j]).abs()).sum::<f32>() / 2.0
        })
        .collect();
    errs.sort_by(f32::total_cmp);
    let median = errs[errs.len() / 2];
    let p90 = errs[errs.len() * 9 / 10];
    // Half the L1 distance = the weight mass that differs. The grid (2.9 cm cells here) blurs
    // it a little at the joints only.
    assert!(median < 0.03, "median {median}");
    assert!(p90 < 0.15, "p90 {p90}");
    // Along the normal, nothing changes (within the near-surface band).
    let normals = body.mesh(c.rest.clone()).vertex_normals();
    let mut along: Vec<f32> = (0..c.rest.len())
        .step_by(11)
        .map(|v| {
            let a = c.field.weights_at(c.rest[v] + normals[v] * 0.01);
            let b = c.field.weights_at(c.rest[v] + normals[v] * 0.03);
            (0..NUM_JOINTS).map(|j| (a[j] - b[j]).abs()).sum::<f32>() / 2.0
        })
        .collect();
    along.sort_by(f32::total_cmp);
    assert!(along[along.len() / 2] < 0.02, "{}", along[along.len() / 2]);
}

fn library_poses() -> Vec<BodyParams> {
    let mut out = Vec::new();
    for name in ["walk", "squat", "raise_arms", "kick"] {
        let clip = clip_by_name(name).unwrap();
        out.push(clip.frames[clip.len() / 3].clone());
        out.push(clip.frames[2 * clip.len() / 3].clone());
    }
    out
}

#[test]
fn root_finding_recovers_known_canonical_points() {
    let c = canon();
    let body = open_body_ref();
    let normals = body.mesh(c.rest.clone()).vertex_normals();
    // Points on and off the body (up to 10 cm out, like clothing), skipping hands and feet.
    let pts: Vec<(Vec3, Vec3)> = (0..c.rest.len())
        .step_by(53)
        .filter(|&v| {
            !matches!(
                avatar_core::body::skinning::dominant_joint(&body.weights[v]),
                7 | 8 | 10 | 11 | 20 | 21 | 22 | 23
            )
        })
        .enumerate()
        .map(|(k, v)| (c.rest[v] + normals[v] * (0.1 * (k % 5) as f32 / 4.0), normals[v]))
        .collect();
    let (mut ok, mut total) = (0, 0);
    for p in library_poses() {
        let posed = body.pose(&p);
        let posed_pts: Vec<Vec3> =
            pts.iter().map(|(x, _)| forward_point(&c.field, &posed.bones.transforms, *x)).collect();
        let posed_normals: Vec<Vec3> = pts.iter().map(|(_, n)| *n).collect();
        let frame = canonicalize_points(
            &c.field,
            &posed.bones,
            &posed.vertices,
            &body.weights,
            &posed_pts,
            &posed_normals,
            &c.options,
            None,
        );
        for (k, &src) in frame.source.iter().enumerate() {
            total += 1;
            if (frame.points[k] - pts[src].0).length() < 0.002 {
                ok += 1;
            }
        }
        assert!(
            frame.points.len() as f32 > 0.95 * pts.len() as f32,
            "{} of {} solved",
            frame.points.len(),
            pts.len()
        );
    }
    assert!(ok as f32 > 0.95 * total as f32, "{ok} of {total} roots within 2 mm of the truth");
}

#[test]
fn forward_then_inverse_round_trip_of_a_mesh() {
    let c = canon();
    let body = open_body_ref();
    let p = &library_poses()[1];
    let posed = body.pose(p);
    let canonical = body.mesh(c.rest.clone());
    let skinned = forward_skin_mesh(&c.field, &posed.bones, &canonical);
    // The field-skinned body is close to the body's own LBS (same weights on the surface).
    let mut d: Vec<f32> =
        skinned.positions.iter().zip(&posed.vertices).map(|(a, b)| (*a - *b).length()).collect();
    d.sort_by(f32::total_cmp);
    assert!(d[d.len() / 2] < 0.005, "median {}", d[d.len() / 2]);
    let sample: Vec<usize> = (0..skinned.positions.len()).step_by(97).collect();
    let pts: Vec<Vec3> = sample.iter().map(|&i| skinned.positions[i]).collect();
    let ns = vec![Vec3::Y; pts.len()];
    let frame = canonicalize_points(
        &c.field,
        &posed.bones,
        &posed.vertices,
        &body.weights,
        &pts,
        &ns,
        &c.options,
        None,
    );
    let back = frame
        .source
        .iter()
        .zip(&frame.points)
        .filter(|(s, x)| (**x - c.rest[sample[**s]]).length() < 0.002)
        .count();
    assert!(back as f32 > 0.95 * pts.len() as f32, "{back} of {}", pts.len());
    assert_eq!(frame.dropped, 0);
}

#[test]
fn normalisation_round_trip_and_range() {
    let c = canon();
    let n = c.normalisation;
    let mut extent: f32 = 0.0;
    for p in &c.rest {
        let q = n.to_unit(*p);
        extent = extent.max(q.abs().max_element());
        assert!((n.from_unit(q) - *p).length() < 1e-5);
    }
    assert!((extent - 0.909).abs() < 0.01, "body spans +-{extent}");
}

#[test]
fn cache_round_trip_and_corrupt_cache_rebuilt() {
    let dir = tempfile::tempdir().unwrap();
    let body = open_body_ref();
    let rest = body.shaped_vertices(&[]);
    let opts =
        FieldOptions { cells_along_height: 40, smoothing_iterations: 4, ..FieldOptions::default() };
    let (a, w) = cached_field(body, &rest, &opts, Some(dir.path())).unwrap();
    assert!(w.is_none());
    let (b, w) = cached_field(body, &rest, &opts, Some(dir.path())).unwrap();
    assert!(w.is_none());
    assert_eq!(a.dims, b.dims);
    // The first run's field is the one later runs read back, to the bit: both fit one avatar.
    assert_eq!(a.weights, b.weights, "the built field differs from the cached one");
    assert_eq!((a.origin, a.cell), (b.origin, b.cell));
    // And it is the full-precision field to within the compact form's rounding.
    let full = avatar_core::canonical::SkinningField::build(body, &rest, &opts).unwrap();
    for p in rest.iter().step_by(31) {
        let (wa, wf) = (a.weights_at(*p), full.weights_at(*p));
        let diff: f32 = (0..NUM_JOINTS).map(|j| (wa[j] - wf[j]).abs()).sum();
        assert!(diff < 0.05, "the cached field differs from the built one by {diff}");
    }
    let file = std::fs::read_dir(dir.path()).unwrap().next().unwrap().unwrap().path();
    let bytes = std::fs::read(&file).unwrap();
    std::fs::write(&file, &bytes[..bytes.len() / 2]).unwrap();
    let (_, w) = cached_field(body, &rest, &opts, Some(dir.path())).unwrap();
    assert!(w.unwrap().contains("truncated"));
    // And the rebuilt cache is good again.
    let (_, w) = cached_field(body, &rest, &opts, Some(dir.path())).unwrap();
    assert!(w.is_none());
}

/// A squat and a bend press the thighs to the belly: there inverse skinning has several roots,
/// and the one kept must be the one nearest the body. The previous choice (the root whose field
/// weights best agree with its start bone) sent about a tenth of such a frame's points more
/// than 10 cm off the canonical body, where a fit grows sheets (docs/decisions.md).
#[test]
fn roots_of_a_squat_and_a_bend_stay_on_the_body() {
    use avatar_core::capture::Capture;
    use avatar_core::mesh::bvh::Bvh;
    use avatar_core::motion::MotionClip;
    use avatar_core::synth::{Outfit, SynthJob, generate_capture};
    let frames: Vec<BodyParams> = ["squat", "bend"]
        .iter()
        .map(|n| clip_by_name(n).unwrap())
        .map(|c| c.frames[c.len() / 2].clone())
        .collect();
    let dir = std::env::temp_dir().join(format!("canonical-squat-{}", std::process::id()));
    let mut job =
        SynthJob::new(1001, Outfit::LongsleeveTrousers, MotionClip::new("deep", 30.0, frames));
    job.write_ground_truth = false;
    generate_capture(&dir, open_body_ref(), &job).unwrap();
    let capture = Capture::open(&dir).unwrap();
    let c = Canonicalizer::new(
        open_body_ref(),
        &capture.frames[0].params.betas,
        &FieldOptions::default(),
        None,
    )
    .unwrap();
    let rest_surface = Bvh::build(&open_body_ref().mesh(c.rest.clone()));
    let far_share = |points: &[Vec3]| {
        points
            .iter()
            .filter(|p| rest_surface.closest_point(**p).is_none_or(|h| h.distance > 0.10))
            .count() as f32
            / points.len().max(1) as f32
    };
    for frame in &capture.frames {
        let kept = c.frame(frame);
        assert!(kept.points.len() > 1000, "{} points kept", kept.points.len());
        let now = far_share(&kept.points);
        assert!(
            now < 0.005,
            "frame {}: {:.1} % of the canonical points lie more than 10 cm off the body",
            frame.index,
            now * 100.0
        );
        // The old choice on the same frame: the test would fail with it.
        let posed = open_body_ref().pose(&frame.params);
        let old = canonicalize_points(
            &c.field,
            &posed.bones,
            &posed.vertices,
            &open_body_ref().weights,
            &frame.points,
            &frame.normals,
            &c.options,
            None,
        );
        assert!(
            far_share(&old.points) > 0.03,
            "frame {}: the agreement choice kept {:.1} % far points",
            frame.index,
            far_share(&old.points) * 100.0
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn warm_started_roots_after_a_small_pose_change_are_the_full_search_roots() {
    use avatar_core::capture::Capture;
    use avatar_core::mesh::bvh::Bvh;
    use avatar_core::motion::MotionClip;
    use avatar_core::synth::{Outfit, SynthJob, generate_capture};
    let frames: Vec<BodyParams> = ["squat", "walk"]
        .iter()
        .map(|n| clip_by_name(n).unwrap())
        .map(|c| c.frames[c.len() / 2].clone())
        .collect();
    let dir = std::env::temp_dir().join(format!("canonical-warm-{}", std::process::id()));
    let mut job = SynthJob::new(1002, Outfit::Dress, MotionClip::new("warm", 30.0, frames));
    job.write_ground_truth = false;
    generate_capture(&dir, open_body_ref(), &job).unwrap();
    let capture = Capture::open(&dir).unwrap();
    let body = open_body_ref();
    let c =
        Canonicalizer::new(body, &capture.frames[0].params.betas, &FieldOptions::default(), None)
            .unwrap();
    let rest_surface = Bvh::build(&body.mesh(c.rest.clone()));
    let distance =
        |x: Vec3, _cap: f32| rest_surface.closest_point(x).map_or(f32::INFINITY, |h| h.distance);
    for frame in &capture.frames {
        let given = c.frame(frame);
        assert_eq!(given.ambiguous.len(), given.points.len());
        let unambiguous = given.ambiguous.iter().filter(|a| !**a).count();
        assert!(
            unambiguous as f32 > 0.75 * given.points.len() as f32,
            "frame {}: {unambiguous} of {} points unambiguous",
            frame.index,
            given.points.len()
        );
        // A refinement round's correction: a degree about a different axis at every joint and
        // 5 mm of translation.
        let mut params = frame.params.clone();
        for (j, r) in params.pose.iter_mut().enumerate() {
            let axis = Vec3::new((j % 3) as f32 - 1.0, 1.0, (j % 2) as f32).normalize();
            *r = (glam::Quat::from_scaled_axis(*r)
                * glam::Quat::from_axis_angle(axis, 1f32.to_radians()))
            .to_scaled_axis();
        }
        params.trans += Vec3::new(0.005, -0.003, 0.002);
        let posed = body.pose(&params);
        let points: Vec<Vec3> = given.source.iter().map(|&i| frame.points[i]).collect();
        let normals: Vec<Vec3> = given.source.iter().map(|&i| frame.normals[i]).collect();
        let warm: Vec<Option<Vec3>> =
            given.points.iter().zip(&given.ambiguous).map(|(&x, &a)| (!a).then_some(x)).collect();
        let solve = |warm: &[Option<Vec3>]| {
            canonicalize_points_from(
                &c.field,
                &posed.bones,
                &posed.vertices,
                &body.weights,
                &points,
                &normals,
                warm,
                &c.options,
                RootPick::Nearest(&distance),
            )
        };
        let (full, warmed) = (solve(&[]), solve(&warm));
        // The roots moved with the pose (the warm start is not simply kept)...
        let moved = full
            .points
            .iter()
            .zip(&full.source)
            .filter(|(x, i)| (**x - given.points[**i]).length() > 1e-3)
            .count();
        assert!(moved * 2 > full.points.len(), "{moved} of {} roots moved", full.points.len());
        // ...and the warm starts found the roots the search from every start bone picks.
        let same = |a: &CanonicalFrame, b: &CanonicalFrame| {
            let mut at = vec![None; points.len()];
            a.source.iter().zip(&a.points).for_each(|(&i, &x)| at[i] = Some(x));
            b.source
                .iter()
                .zip(&b.points)
                .filter(|(i, x)| at[**i].is_some_and(|y: Vec3| (y - **x).length() < 1e-4))
                .count()
        };
        let agree = same(&full, &warmed);
        assert!(
            agree as f32 >= 0.998 * full.points.len() as f32
                && warmed.points.len().abs_diff(full.points.len()) * 500 <= full.points.len(),
            "frame {}: {agree} of {} roots agree ({} kept warm)",
            frame.index,
            full.points.len(),
            warmed.points.len()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A field diffused from any surface with weights (FITE's clothed template): on a square
/// sheet whose left edge belongs to joint 1 and right edge to joint 2, the field on the sheet
/// is the linear blend of the two, the same a little off the sheet along its normal, and a
/// surface with the wrong number of weights is refused.
#[test]
fn a_field_built_around_a_weighted_sheet_blends_its_weights() {
    use avatar_core::mesh::TriMesh;
    let n = 11;
    let mut positions = Vec::new();
    let mut weights = Vec::new();
    for row in 0..n {
        for col in 0..n {
            let t = col as f32 / (n - 1) as f32;
            positions.push(Vec3::new(t - 0.5, row as f32 / (n - 1) as f32, 0.0));
            let mut w = [0.0; NUM_JOINTS];
            (w[1], w[2]) = (1.0 - t, t);
            weights.push(w);
        }
    }
    let mut faces = Vec::new();
    for row in 0..n - 1 {
        for col in 0..n - 1 {
            let i = (row * n + col) as u32;
            faces.push([i, i + 1, i + n as u32]);
            faces.push([i + 1, i + n as u32 + 1, i + n as u32]);
        }
    }
    let sheet = TriMesh::new(positions, faces);
    let options = FieldOptions { cells_along_height: 40, margin: 0.2, ..FieldOptions::default() };
    let field = SkinningField::build_around(&sheet, &weights, &options).unwrap();
    for (x, off) in [(-0.3f32, 0.0f32), (0.0, 0.02), (0.25, -0.02), (0.4, 0.0)] {
        let w = field.weights_at(Vec3::new(x, 0.5, off));
        let t = x + 0.5;
        assert!((w[1] - (1.0 - t)).abs() < 0.02 && (w[2] - t).abs() < 0.02, "at x = {x}: {w:?}");
        assert!((w[1] + w[2] - 1.0).abs() < 1e-4);
    }
    let err = SkinningField::build_around(&sheet, &weights[1..], &options).unwrap_err();
    assert!(err.to_string().contains("skinning weights"), "{err}");
}
