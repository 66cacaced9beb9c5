use super::*;
use crate::mesh::extract::{ExtractOptions, extract};
use crate::synth::raster::tests::sphere;

/// A 10 cm sphere with a finger: a 1 cm sphere at `x` on the +x axis, its vertices from the
/// returned index on.
fn body_with_finger(x: f32) -> (BodyWrap, u32) {
    let (p, f) = sphere(Vec3::ZERO, 0.1, 32, 64);
    let mut body = TriMesh::new(p, f);
    let (rp, rf) = sphere(Vec3::new(x, 0.0, 0.0), 0.005, 8, 16);
    let base = body.positions.len() as u32;
    body.positions.extend(rp);
    body.faces.extend(rf.iter().map(|t| t.map(|v| v + base)));
    (BodyWrap::of_mesh(body), base)
}

fn body() -> BodyWrap {
    let (p, f) = sphere(Vec3::ZERO, 0.1, 48, 96);
    BodyWrap::of_mesh(TriMesh::new(p, f))
}

#[test]
fn cloth_a_centimetre_out_is_reached_along_every_normal() {
    let wrap = body();
    // Cloth 1 cm out on one side, 3 cm on the other.
    let cloth = |p: Vec3| 0.11 + 0.01 * (p.x / p.length().max(1e-6)).max(0.0) * 2.0;
    let w = wrap.wrap(|ps| ps.iter().map(|&p| p.length() - cloth(p)).collect());
    assert!(w.found.iter().all(|&f| f));
    for p in &w.mesh.positions {
        assert!(
            (p.length() - cloth(*p)).abs() < 3e-4,
            "{p} at {} m, cloth at {}",
            p.length(),
            cloth(*p)
        );
    }
}

#[test]
fn a_surface_out_of_reach_leaves_the_body_where_it_is() {
    let wrap = body();
    // A blob 8 cm out (beyond the 6 cm band) over the +y cap, cloth 5 mm out elsewhere.
    let w = wrap.wrap(|ps| {
        ps.iter().map(|&p| p.length() - if p.y > 0.08 { 0.18 } else { 0.105 }).collect()
    });
    for ((p, &found), rest) in w.mesh.positions.iter().zip(&w.found).zip(&wrap.rest.positions) {
        if rest.y > 0.085 {
            assert!(!found);
            assert_eq!(p, rest);
        } else if rest.y < 0.07 {
            assert!(found);
            assert!((p.length() - 0.105).abs() < 3e-4);
        }
    }
}

#[test]
fn tight_cloth_is_covered_and_a_skirt_is_not() {
    let wrap = body();
    let opts = ExtractOptions::new(Vec3::splat(-0.25), Vec3::splat(0.25), 64);
    let tight = |p: &Vec3| p.length() - 0.108;
    let w = wrap.wrap(|ps| ps.iter().map(tight).collect());
    let extracted = extract(|ps: &[Vec3]| ps.iter().map(tight).collect(), &opts).unwrap().mesh;
    assert!(wrap.uncovered_share(&w.mesh, &extracted) < 0.005);
    assert!(wrap.covers(&w.mesh, &extracted));
    // A "skirt": a flat disc 12 cm wide around the equator, 4 mm thick (a sheet far from
    // the body over most of its area), unioned with the tight cloth.
    let skirt =
        |p: &Vec3| tight(p).min((p.y.abs() - 0.002).max(Vec3::new(p.x, 0.0, p.z).length() - 0.22));
    let w = wrap.wrap(|ps| ps.iter().map(skirt).collect());
    let extracted = extract(|ps: &[Vec3]| ps.iter().map(skirt).collect(), &opts).unwrap().mesh;
    let share = wrap.uncovered_share(&w.mesh, &extracted);
    assert!(share > 0.2, "the skirt's share beyond 1.5 cm: {share}");
    assert!(!wrap.covers(&w.mesh, &extracted));
}

#[test]
fn a_skirt_comes_beside_the_body_and_meets_it() {
    let wrap = body();
    let opts = ExtractOptions::new(Vec3::splat(-0.25), Vec3::splat(0.25), 64);
    // Tight cloth 8 mm out, and a brim (a flat ring 4 mm thick out to 22 cm) round the
    // equator: the brim is the loose piece.
    let tight = |p: &Vec3| p.length() - 0.108;
    let brim = |p: &Vec3| (p.y.abs() - 0.002).max(Vec3::new(p.x, 0.0, p.z).length() - 0.22);
    let sdf = |p: &Vec3| tight(p).min(brim(p));
    let w = wrap.wrap_within(|ps| ps.iter().map(sdf).collect(), wrap.options.tight_outside);
    let extracted = extract(|ps: &[Vec3]| ps.iter().map(sdf).collect(), &opts).unwrap().mesh;
    let merged = wrap.with_loose_pieces(&w.mesh, &extracted, |ps| ps.iter().map(sdf).collect());
    let n = wrap.vertex_count();
    // The body's vertices first, on the tight cloth (or on the body where the brim's root
    // swallowed them).
    assert_eq!(&merged.positions[..n], &w.mesh.positions[..]);
    let pieces = &merged.positions[n..];
    assert!(!pieces.is_empty());
    // Every piece vertex is on the brim, and the brim reaches out to its rim.
    assert!(
        pieces.iter().all(|p| brim(p).abs() < 0.004 || tight(p).abs() < 0.004),
        "a piece vertex off the brim"
    );
    let reach = pieces.iter().map(|p| Vec3::new(p.x, 0.0, p.z).length()).fold(0f32, f32::max);
    assert!(reach > 0.21, "the brim reaches {reach} m");
    // Its inner border was put on the wrapped body: no piece vertex hangs in the gap
    // between 1 mm and 1.2 cm from the tight cloth near the brim's root.
    let gap = pieces
        .iter()
        .filter(|p| {
            Vec3::new(p.x, 0.0, p.z).length() < 0.12 && tight(p) > 0.001 && tight(p) < 0.012
        })
        .count();
    assert_eq!(gap, 0);
    // Every face index is valid.
    assert!(merged.faces.iter().all(|f| f.iter().all(|&v| (v as usize) < merged.positions.len())));
}

#[test]
fn the_body_and_a_pieces_seam_take_the_bodys_own_weights() {
    let wrap = body();
    // Body weights that vary over the sphere: joint 0 at the top, joint 1 at the bottom.
    let body_weights: Vec<Weights> = wrap
        .rest
        .positions
        .iter()
        .map(|p| {
            let mut w = [0.0; crate::body::NUM_JOINTS];
            w[0] = 0.5 + 5.0 * p.y;
            w[1] = 1.0 - w[0];
            w
        })
        .collect();
    let opts = ExtractOptions::new(Vec3::splat(-0.25), Vec3::splat(0.25), 64);
    let tight = |p: &Vec3| p.length() - 0.108;
    let brim = |p: &Vec3| (p.y.abs() - 0.002).max(Vec3::new(p.x, 0.0, p.z).length() - 0.22);
    let sdf = |p: &Vec3| tight(p).min(brim(p));
    let w = wrap.wrap_within(|ps| ps.iter().map(sdf).collect(), wrap.options.tight_outside);
    let extracted = extract(|ps: &[Vec3]| ps.iter().map(sdf).collect(), &opts).unwrap().mesh;
    let merged = wrap.with_loose_pieces(&w.mesh, &extracted, |ps| ps.iter().map(sdf).collect());
    let n = wrap.vertex_count();
    // "Field" weights: all on joint 2, so any vertex that took the body's shows it.
    let mut field = [0.0; crate::body::NUM_JOINTS];
    field[2] = 1.0;
    let weights = wrap.own_weights(&body_weights, &merged, vec![field; merged.positions.len()]);
    assert_eq!(&weights[..n], &body_weights[..]);
    let bvh = Bvh::build(&TriMesh::new(merged.positions[..n].to_vec(), wrap.rest.faces.clone()));
    let (mut seam, mut free) = (0, 0);
    for (p, w) in merged.positions[n..].iter().zip(&weights[n..]) {
        if bvh.closest_point_within(*p, 1e-6).is_some() {
            // On the wrapped body (moved out radially), with the body's weights of the
            // rest point beneath it.
            seam += 1;
            let expected = 0.5 + 5.0 * p.y * 0.1 / p.length();
            assert!(
                w[2] == 0.0 && (w[0] - expected).abs() < 0.003 && (w[0] + w[1] - 1.0).abs() < 1e-5,
                "seam vertex {p}: {:?}, expected {expected}",
                &w[..3]
            );
        } else {
            free += 1;
            assert_eq!(*w, field);
        }
    }
    assert!(seam > 20 && free > 100, "{seam} seam and {free} free vertices");
    // A mesh that is not a wrapped body keeps the weights it was given.
    let others = vec![field; extracted.positions.len()];
    assert_eq!(wrap.own_weights(&body_weights, &extracted, others.clone()), others);
}

#[test]
fn a_blob_round_a_finger_is_no_loose_piece_but_a_brim_is() {
    // The 10 cm sphere with a 1 cm finger along +x at 15 cm (`body_with_finger`),
    // cloth 8 mm out, a brim round the equator on the -x side only, and a 2.5 cm blob round
    // the finger from the cloth to its tip (the SDF's guess of a hand).
    let (wrap, _) = body_with_finger(0.15);
    let tight = |p: &Vec3| p.length() - 0.108;
    let brim = |p: &Vec3| {
        (p.y.abs() - 0.002).max(Vec3::new(p.x, 0.0, p.z).length() - 0.22).max(p.x + 0.02)
    };
    let blob = |p: &Vec3| Vec3::new(p.x.clamp(0.09, 0.15) - p.x, p.y, p.z).length() - 0.025;
    let sdf = |p: &Vec3| tight(p).min(brim(p)).min(blob(p));
    let opts = ExtractOptions::new(Vec3::splat(-0.25), Vec3::splat(0.25), 96);
    let w = wrap.wrap_within(|ps| ps.iter().map(sdf).collect(), wrap.options.tight_outside);
    let extracted = extract(|ps: &[Vec3]| ps.iter().map(sdf).collect(), &opts).unwrap().mesh;
    let merged = wrap.with_loose_pieces(&w.mesh, &extracted, |ps| ps.iter().map(sdf).collect());
    let pieces = &merged.positions[wrap.vertex_count()..];
    assert!(pieces.iter().any(|p| p.x < -0.2), "the brim is kept");
    assert!(
        extracted.positions.iter().filter(|p| p.distance(Vec3::new(0.15, 0.0, 0.0)) < 0.03).count()
            > 50,
        "the extracted blob"
    );
    let near_finger =
        pieces.iter().filter(|p| p.distance(Vec3::new(0.15, 0.0, 0.0)) < 0.03).count();
    assert_eq!(near_finger, 0, "no piece round the finger");
}

#[test]
fn a_fragment_of_cloth_is_dropped_and_a_flap_is_kept() {
    // The 10 cm sphere (0.126 m^2, so pieces under 25 cm^2 are fragments), cloth 8 mm
    // out, and two flat discs 4 mm thick well off the cloth: a 1.5 cm one above the body
    // (about 16 cm^2 with its rim) and a 3.5 cm one below it (about 80 cm^2).
    let wrap = body();
    assert!((wrap.rest_area - 0.1257).abs() < 0.002, "{}", wrap.rest_area);
    let tight = |p: &Vec3| p.length() - 0.108;
    let disc = |p: &Vec3, y: f32, r: f32| {
        ((p.y - y).abs() - 0.002).max(Vec3::new(p.x, 0.0, p.z).length() - r)
    };
    let sdf = |p: &Vec3| tight(p).min(disc(p, 0.16, 0.015)).min(disc(p, -0.16, 0.035));
    let mut opts = ExtractOptions::new(Vec3::splat(-0.25), Vec3::splat(0.25), 96);
    // (Fitted surfaces meet their fragments at the cloth; here they float beside it.)
    opts.largest_component_only = false;
    let w = wrap.wrap_within(|ps| ps.iter().map(sdf).collect(), wrap.options.tight_outside);
    let extracted = extract(|ps: &[Vec3]| ps.iter().map(sdf).collect(), &opts).unwrap().mesh;
    assert!(
        extracted.positions.iter().filter(|p| p.y > 0.15).count() > 20,
        "the fragment is extracted"
    );
    let merged = wrap.with_loose_pieces(&w.mesh, &extracted, |ps| ps.iter().map(sdf).collect());
    let pieces = &merged.positions[wrap.vertex_count()..];
    assert_eq!(pieces.iter().filter(|p| p.y > 0.14).count(), 0, "the fragment is dropped");
    assert!(pieces.iter().filter(|p| p.y < -0.14).count() > 20, "the flap is kept");
    let mut smaller = body();
    smaller.options.min_piece_share = 0.005;
    let merged = smaller.with_loose_pieces(&w.mesh, &extracted, |ps| ps.iter().map(sdf).collect());
    assert!(
        merged.positions[wrap.vertex_count()..].iter().any(|p| p.y > 0.14),
        "kept at a lower share"
    );
}

#[test]
fn a_body_too_thin_to_resolve_is_not_wrapped() {
    let (wrap, base) = body_with_finger(0.14);
    // A blob 2 cm round the small sphere (the SDF's guess of a finger), cloth 5 mm out elsewhere.
    let w = wrap.wrap(|ps| {
        ps.iter()
            .map(|&p| (p.length() - 0.105).min(p.distance(Vec3::new(0.14, 0.0, 0.0)) - 0.02))
            .collect()
    });
    for v in base as usize..w.mesh.positions.len() {
        assert!(
            !w.found[v],
            "vertex {v} thickness {} normal {}",
            wrap.thickness[v], wrap.normals[v]
        );
        assert_eq!(w.mesh.positions[v], wrap.rest.positions[v]);
    }
    assert!(w.found[..base as usize].iter().filter(|&&f| f).count() > base as usize * 9 / 10);
}

/// A torus round the y axis (ring radius `big`, tube radius `small`), faces outward.
fn torus(big: f32, small: f32, rings: usize, tubes: usize) -> TriMesh {
    let mut positions = Vec::new();
    for i in 0..rings {
        let u = i as f32 / rings as f32 * std::f32::consts::TAU;
        for j in 0..tubes {
            let v = j as f32 / tubes as f32 * std::f32::consts::TAU;
            let r = big + small * v.cos();
            positions.push(Vec3::new(r * u.cos(), small * v.sin(), r * u.sin()));
        }
    }
    let at = |i: usize, j: usize| ((i % rings) * tubes + j % tubes) as u32;
    let mut faces = Vec::new();
    for i in 0..rings {
        for j in 0..tubes {
            faces.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
            faces.push([at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]);
        }
    }
    TriMesh::new(positions, faces)
}

#[test]
fn an_offset_wider_than_a_crease_stops_short_of_folding_and_keeps_its_size_elsewhere() {
    // The inside of a torus is a crease: the ball touching its inner equator from outside is
    // 4 cm wide (the hole's radius), while cloth lies 5 cm out all round.
    let (big, small, cloth) = (0.1, 0.06, 0.05);
    let mut body = torus(big, small, 96, 48);
    if body.signed_volume() < 0.0 {
        body.faces.iter_mut().for_each(|f| f.swap(1, 2));
    }
    let sdf = |ps: &[Vec3]| -> Vec<f32> {
        ps.iter()
            .map(|p| Vec3::new(p.x.hypot(p.z) - big, p.y, 0.0).length() - small - cloth)
            .collect()
    };
    let wrap = BodyWrap::of_mesh(body.clone());
    let folds = |w: &Wrapped| {
        crate::mesh::integrity::self_intersecting_faces(&w.mesh.positions, &w.mesh.faces)
            .iter()
            .filter(|&&f| f)
            .count()
    };
    let clamped = wrap.wrap(sdf);
    assert_eq!(folds(&clamped), 0, "the wrapped torus intersects itself");
    for (p, rest) in clamped.mesh.positions.iter().zip(&body.positions) {
        let ring = rest.x.hypot(rest.z);
        if ring > big + 0.9 * small {
            // The outside has room: the cloth is reached.
            assert!((p.distance(*rest) - cloth).abs() < 1e-3, "{} m out", p.distance(*rest));
        } else if ring < big - 0.99 * small {
            // The inner equator moves at most `crease_share` of the hole's radius.
            let most = wrap.options.crease_share * (big - small);
            assert!(p.distance(*rest) <= most + 1e-3, "{} m out", p.distance(*rest));
        }
    }
}

/// The open body, its head's vertices, and its signed distance (the surface 4 mm out is the
/// head inflated past its creases: eyelids, nostrils and ears narrower than that).
fn open_body_and_head() -> (TriMesh, Vec<bool>, crate::mesh::signed_distance::SignedDistance) {
    let body = crate::body::open_body_ref();
    let rest = body.mesh(body.shaped_vertices(&[]));
    let head = body.weights.iter().map(|w| w[15] > 0.5).collect();
    let distance = crate::mesh::signed_distance::SignedDistance::new(&rest);
    (rest, head, distance)
}

/// Faces of `mesh` with every vertex in `part` that cross another face.
fn crossing_faces_within(mesh: &TriMesh, part: &[bool]) -> usize {
    crate::mesh::integrity::self_intersecting_faces(&mesh.positions, &mesh.faces)
        .iter()
        .zip(&mesh.faces)
        .filter(|(crossing, f)| **crossing && f.iter().all(|&v| part[v as usize]))
        .count()
}

#[test]
fn a_head_wrapped_a_few_millimetres_out_does_not_run_through_itself() {
    let (rest, head, inflated) = open_body_and_head();
    let sdf = |ps: &[Vec3]| -> Vec<f32> {
        ps.iter().map(|&p| inflated.at(p).unwrap_or(1.0) - 0.004).collect()
    };
    let mut wrap = BodyWrap::of_mesh(rest.clone());
    let crossing_head_faces = |wrap: &BodyWrap| crossing_faces_within(&wrap.wrap(sdf).mesh, &head);
    let head_faces = rest.faces.iter().filter(|f| f.iter().all(|&v| head[v as usize])).count();
    let limited = crossing_head_faces(&wrap);
    wrap.options.crease_share = f32::INFINITY;
    let unlimited = crossing_head_faces(&wrap);
    assert!(
        (limited as f32) < 0.002 * head_faces as f32 && (limited as f32) < 0.2 * unlimited as f32,
        "{limited} of {head_faces} head faces cross others ({unlimited} without the limit)"
    );
}

#[test]
fn a_head_wrapped_past_its_creases_is_spanned_as_a_membrane() {
    // The inflated head of the test above without the creases' limit: hundreds of faces pass
    // through others. Spanned on the head (the default), none is left there; the vertices off
    // the head keep their places to the bit, and the moved ones stay near where they were.
    let (_, head, inflated) = open_body_and_head();
    let sdf = |ps: &[Vec3]| -> Vec<f32> {
        ps.iter().map(|&p| inflated.at(p).unwrap_or(1.0) - 0.004).collect()
    };
    let mut wrap = BodyWrap::new(crate::body::open_body_ref(), &[]);
    wrap.options.crease_share = f32::INFINITY;
    let wrapped = wrap.wrap(sdf).mesh;
    let before = crossing_faces_within(&wrapped, &head);
    assert!(before > 100, "{before} head faces cross");
    wrap.options.span_crossings = SpanCrossings::Nowhere;
    let mut kept = wrapped.clone();
    assert_eq!(wrap.span_crossings(&mut kept), 0);
    assert_eq!(kept.positions, wrapped.positions);
    wrap.options.span_crossings = WrapOptions::default().span_crossings;
    let mut spanned = wrapped.clone();
    assert!(wrap.span_crossings(&mut spanned) >= before);
    assert_eq!(crossing_faces_within(&spanned, &head), 0);
    for (v, (p, q)) in spanned.positions.iter().zip(&wrapped.positions).enumerate() {
        assert!(wrap.head[v] || p == q, "vertex {v} off the head moved");
    }
    // Within the creases' limit (the default) a few faces still cross; spanned, they move a
    // few millimetres at most.
    wrap.options.crease_share = WrapOptions::default().crease_share;
    let wrapped = wrap.wrap(sdf).mesh;
    let mut spanned = wrapped.clone();
    let before = wrap.span_crossings(&mut spanned);
    assert!(before > 0, "no head face crosses within the creases' limit");
    assert_eq!(crossing_faces_within(&spanned, &head), 0);
    let farthest = spanned
        .positions
        .iter()
        .zip(&wrapped.positions)
        .map(|(p, q)| p.distance(*q))
        .fold(0.0, f32::max);
    assert!(farthest < 0.003, "a vertex moved {farthest} m");
}
