use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_soup(rng: &mut ChaCha8Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let mut v = || {
                c + Vec3::new(
                    rng.random_range(-0.2..0.2),
                    rng.random_range(-0.2..0.2),
                    rng.random_range(-0.2..0.2),
                )
            };
            [v(), v(), v()]
        })
        .collect()
}

/// Reference distance: minimise over a fine barycentric sampling of the triangle, then
/// over its edges; an upper bound that is within the sampling step of the truth.
fn sampled_distance(p: Vec3, [a, b, c]: [Vec3; 3]) -> f32 {
    let n = 200;
    let mut best = f32::INFINITY;
    for i in 0..=n {
        for j in 0..=(n - i) {
            let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
            best = best.min((a + (b - a) * u + (c - a) * v).distance(p));
        }
    }
    best
}

#[test]
fn closest_point_on_triangle_matches_dense_sampling() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..200 {
        let tri = random_soup(&mut rng, 1)[0];
        let p = Vec3::new(
            rng.random_range(-1.5..1.5),
            rng.random_range(-1.5..1.5),
            rng.random_range(-1.5..1.5),
        );
        let q = closest_point_on_triangle(p, tri[0], tri[1], tri[2]);
        let exact = q.distance(p);
        let sampled = sampled_distance(p, tri);
        // The closest point must lie on the triangle and no sample may be closer.
        assert!(exact <= sampled + 1e-5, "closest point {exact} farther than a sample {sampled}");
        assert!(sampled - exact < 0.01, "closest point {exact} too close vs samples {sampled}");
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        assert!((q - tri[0]).dot(n).abs() < 1e-4, "closest point off the triangle plane");
    }
}

#[test]
fn bvh_closest_point_equals_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let tris = random_soup(&mut rng, 500);
    let bvh = Bvh::from_triangles(tris.clone());
    for _ in 0..500 {
        let q = Vec3::new(
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
        );
        let hit = bvh.closest_point(q).unwrap();
        let (brute_face, brute) = tris
            .iter()
            .enumerate()
            .map(|(f, t)| (f, closest_point_on_triangle(q, t[0], t[1], t[2]).distance(q)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!((hit.distance - brute).abs() < 1e-6, "bvh {} vs brute {brute}", hit.distance);
        assert!((hit.point.distance(q) - hit.distance).abs() < 1e-5);
        // Ties aside, the face must be the brute-force one.
        let t = tris[hit.face as usize];
        assert!(
            (closest_point_on_triangle(q, t[0], t[1], t[2]).distance(q)
                - tris_dist(&tris, brute_face, q))
            .abs()
                < 1e-6
        );
    }
    assert!(bvh.closest_point_within(Vec3::splat(10.0), 1.0).is_none());
    assert!(Bvh::from_triangles(Vec::new()).closest_point(Vec3::ZERO).is_none());
}

fn tris_dist(tris: &[[Vec3; 3]], f: usize, q: Vec3) -> f32 {
    let t = tris[f];
    closest_point_on_triangle(q, t[0], t[1], t[2]).distance(q)
}

#[test]
fn bvh_rays_equal_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let tris = random_soup(&mut rng, 300);
    let bvh = Bvh::from_triangles(tris.clone());
    for _ in 0..300 {
        let o = Vec3::new(
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
        );
        let d = (Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ) - o * 0.3)
            .normalize();
        let mut brute: Vec<f32> = tris
            .iter()
            .filter_map(|t| ray_triangle(o, d, t[0], t[1], t[2]).map(|h| h.0))
            .filter(|&t| t > 0.0 && t < 100.0)
            .collect();
        brute.sort_by(f32::total_cmp);
        let hits = bvh.ray_hits(o, d, 0.0, 100.0);
        assert_eq!(hits.len(), brute.len());
        for (h, t) in hits.iter().zip(&brute) {
            assert!((h.t - t).abs() < 1e-6);
        }
        let first = bvh.ray_cast(o, d, 0.0, 100.0).map(|h| h.t);
        assert_eq!(first, brute.first().copied());
    }
    // Axis-parallel rays (infinite inverse components) work too.
    let hits = bvh.ray_hits(Vec3::new(0.1, 0.2, -5.0), Vec3::Z, 0.0, 100.0);
    let brute = tris
        .iter()
        .filter(|t| {
            ray_triangle(Vec3::new(0.1, 0.2, -5.0), Vec3::Z, t[0], t[1], t[2])
                .is_some_and(|h| h.0 > 0.0)
        })
        .count();
    assert_eq!(hits.len(), brute);
}

#[test]
fn ray_reports_front_and_back_side() {
    // Triangle in z = 0 with normal +z.
    let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
    let down = ray_triangle(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, a, b, c).unwrap();
    assert!(down.3 && (down.0 - 1.0).abs() < 1e-6);
    let up = ray_triangle(Vec3::new(0.2, 0.2, -1.0), Vec3::Z, a, b, c).unwrap();
    assert!(!up.3);
    assert!(ray_triangle(Vec3::new(0.8, 0.8, 1.0), -Vec3::Z, a, b, c).is_none());
}

#[test]
fn a_ray_along_a_box_face_plane_still_finds_the_triangles_beyond() {
    // Upright triangles at x = 1..40 whose boxes all start at y = 0, and a ray along +x
    // from a point on that plane (y = 0 exactly, so 0 * inf meets the slab test).
    let tris: Vec<[Vec3; 3]> = (1..40)
        .map(|i| {
            let x = i as f32;
            [Vec3::new(x, 0.0, -1.0), Vec3::new(x, 0.0, 1.0), Vec3::new(x, 1.0, 0.0)]
        })
        .collect();
    let bvh = Bvh::from_triangles(tris);
    let hit = bvh
        .ray_cast(Vec3::new(0.0, 0.0, 0.5), Vec3::X, 0.0, 100.0)
        .expect("the first triangle lies 1 m ahead");
    assert!((hit.t - 1.0).abs() < 1e-6, "hit at {}", hit.t);
    assert_eq!(bvh.ray_hits(Vec3::new(0.0, 0.0, 0.5), Vec3::X, 0.0, 100.0).len(), 39);
    // Beside the slab (y < 0) the same ray misses every box.
    assert!(bvh.ray_cast(Vec3::new(0.0, -0.01, 0.5), Vec3::X, 0.0, 100.0).is_none());
}

#[test]
fn a_hinted_query_answers_as_the_plain_one_whatever_the_hint() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    // A soup, and a folded grid whose shared corners and edges tie several faces.
    let soup = Bvh::from_triangles(random_soup(&mut rng, 300));
    let n = 12;
    let at = |i: usize, j: usize| {
        let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
        Vec3::new(x, (3.0 * x).sin() * 0.3 * (x - 0.5).abs(), z)
    };
    let mut grid = Vec::new();
    for i in 0..n {
        for j in 0..n {
            grid.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            grid.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let grid_points: Vec<Vec3> = (0..=n)
        .flat_map(|i| (0..=n).map(move |j| (i, j)))
        .map(|(i, j)| at(i, j) + Vec3::new(0.0, 0.05, 0.0))
        .collect();
    let grid = Bvh::from_triangles(grid);
    for (bvh, extra) in [(&soup, Vec::new()), (&grid, grid_points)] {
        let mut points: Vec<Vec3> =
            (0..300).map(|_| random_point(&mut rng, Vec3::splat(-1.5), Vec3::splat(1.5))).collect();
        points.extend(extra);
        for p in points {
            let plain = bvh.closest_point(p).unwrap();
            let faces = bvh.num_triangles() as u32;
            for hint in [plain.face, rng.random_range(0..faces), (plain.face + 1) % faces, faces] {
                assert_eq!(bvh.closest_point_hinted(p, hint), Some(plain), "{p} hint {hint}");
            }
        }
    }
    assert_eq!(Bvh::from_triangles(Vec::new()).closest_point_hinted(Vec3::ZERO, 0), None);
}

/// The brute-force answer the tree must give bit for bit: the least computed squared distance,
/// and of equal ones the lowest face index.
fn brute_closest(tris: &[[Vec3; 3]], q: Vec3) -> (u32, Vec3, f32) {
    let mut best = (u32::MAX, Vec3::ZERO, f32::INFINITY);
    for (f, t) in tris.iter().enumerate() {
        let p = closest_point_on_triangle(q, t[0], t[1], t[2]);
        let d2 = p.distance_squared(q);
        if d2 < best.2 {
            best = (f as u32, p, d2);
        }
    }
    best
}

/// A grid of `n` x `n` quads over a bumpy sheet: its shared corners tie up to six faces.
fn bumpy_grid(n: usize) -> Vec<[Vec3; 3]> {
    let at = |i: usize, j: usize| {
        let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
        Vec3::new(x, 0.1 * (7.0 * x).sin() * (5.0 * z).cos(), z)
    };
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..n {
            tris.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            tris.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    tris
}

#[test]
fn closest_points_are_the_brute_force_ones_ties_to_the_lowest_face() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let grid = bumpy_grid(20);
    // Above every corner (a tie of the faces around it), and anywhere.
    let mut points: Vec<Vec3> = grid.iter().flatten().map(|&p| p + Vec3::Y * 0.03).collect();
    points.extend((0..400).map(|_| random_point(&mut rng, Vec3::splat(-0.5), SLAB_MAX)));
    let soup = random_soup(&mut rng, 400);
    for tris in [grid, soup] {
        let bvh = Bvh::from_triangles(tris.clone());
        let mut ties = 0;
        for &q in &points {
            let (face, point, d2) = brute_closest(&tris, q);
            let hit = bvh.closest_point(q).unwrap();
            assert_eq!((hit.face, hit.point, hit.distance), (face, point, d2.sqrt()), "{q}");
            let t = &tris[face as usize];
            ties += tris
                .iter()
                .filter(|u| *u != t)
                .filter(|u| {
                    closest_point_on_triangle(q, u[0], u[1], u[2]).distance_squared(q) == d2
                })
                .count()
                .min(1);
        }
        // The grid's corners do tie: the rule is exercised.
        if tris.len() == 800 {
            assert!(ties > 100, "only {ties} ties");
        }
    }
}

#[test]
fn first_ray_hits_are_the_brute_force_ones_ties_to_the_lowest_face() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let grid = bumpy_grid(16);
    let bvh = Bvh::from_triangles(grid.clone());
    // Straight down through every corner (a tie of the faces around it), and at random.
    let mut rays: Vec<(Vec3, Vec3)> =
        grid.iter().flatten().map(|&p| (p + Vec3::Y, -Vec3::Y)).collect();
    rays.extend((0..300).map(|_| {
        let o = Vec3::new(rng.random_range(0.0..1.0), 1.0, rng.random_range(0.0..1.0));
        let d = Vec3::new(rng.random_range(-0.5..0.5), -1.0, rng.random_range(-0.5..0.5));
        (o, d.normalize())
    }));
    for (o, d) in rays {
        let mut brute: Option<(f32, u32)> = None;
        for (f, t) in grid.iter().enumerate() {
            if let Some((t, ..)) = ray_triangle(o, d, t[0], t[1], t[2])
                && t > 0.0
                && t < 10.0
                && brute.is_none_or(|b| t < b.0)
            {
                brute = Some((t, f as u32));
            }
        }
        assert_eq!(bvh.ray_cast(o, d, 0.0, 10.0).map(|h| (h.t, h.face)), brute, "{o} {d}");
        let hits = bvh.ray_hits(o, d, 0.0, 10.0);
        assert!(hits.windows(2).all(|w| (w[0].t, w[0].face) < (w[1].t, w[1].face)));
    }
}

#[test]
fn a_tree_the_heuristic_makes_deep_still_answers() {
    // Triangles whose sizes double along x: the surface area heuristic peels off the small
    // ones a few at a time, level after level (the depth is capped, then median splits).
    let mut tris = Vec::new();
    for i in 0..120 {
        let x = 1.2f32.powi(i);
        for k in 0..3 {
            let y = k as f32 * x;
            tris.push([
                Vec3::new(x, y, 0.0),
                Vec3::new(x * 1.1, y, 0.0),
                Vec3::new(x, y + x * 0.1, 0.1 * x),
            ]);
        }
    }
    let bvh = Bvh::from_triangles(tris.clone());
    for i in 0..120 {
        let q = Vec3::new(1.2f32.powi(i) * 1.05, 0.01, 1.0);
        let (face, point, _) = brute_closest(&tris, q);
        let hit = bvh.closest_point(q).unwrap();
        assert_eq!((hit.face, hit.point), (face, point));
    }
}

/// `any_within` is `closest_point_within(..).is_some()` without the search for the closest:
/// the same answer at every radius, the exact distance (exclusive) and either side of it
/// included.
#[test]
fn any_within_answers_as_the_closest_point_within() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let points: Vec<Vec3> =
        (0..300).map(|_| random_point(&mut rng, Vec3::splat(-0.5), SLAB_MAX)).collect();
    let soup = random_soup(&mut rng, 400);
    let (mut inside, mut outside) = (0, 0);
    for tris in [bumpy_grid(20), soup] {
        let bvh = Bvh::from_triangles(tris.clone());
        for &q in &points {
            let d = bvh.closest_point(q).unwrap().distance;
            for r in [0.0, d * 0.5, d, d.next_up(), d * 1.5, 0.05, 0.3, f32::INFINITY] {
                let expected = bvh.closest_point_within(q, r).is_some();
                assert_eq!(bvh.any_within(q, r), expected, "{q} within {r}");
                // Whatever triangle an earlier query left as the first to try.
                for mut last in [0, 7, 399, u32::MAX] {
                    assert_eq!(bvh.any_within_from(q, r, &mut last), expected, "{q} from {last}");
                }
                if expected { inside += 1 } else { outside += 1 }
            }
        }
    }
    assert!(inside > 500 && outside > 500, "{inside} within, {outside} beyond");
    assert!(!Bvh::from_triangles(Vec::new()).any_within(Vec3::ZERO, 1.0));
}

/// A tree refitted to moved corners answers as a tree built on them: closest points (ties
/// included) and first ray hits bit for bit, though its boxes come from another shape.
#[test]
fn a_refitted_tree_answers_as_a_fresh_build() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let n = 20;
    let grid = bumpy_grid(n);
    let at_rest = TriMesh::new(grid.iter().flatten().copied().collect(), tri_faces(grid.len()));
    // The sheet rolled up a little and shaken: every corner moves, the faces stay.
    let moved = TriMesh::new(
        at_rest
            .positions
            .iter()
            .map(|p| {
                let a = 0.8 * p.x;
                Vec3::new(a.sin(), p.y + 1.0 - a.cos(), p.z)
                    + Vec3::splat(rng.random_range(-0.01..0.01))
            })
            .collect(),
        at_rest.faces.clone(),
    );
    let refitted = Bvh::build(&at_rest).refit(&moved);
    let fresh = Bvh::build(&moved);
    for _ in 0..500 {
        let q = random_point(&mut rng, Vec3::splat(-0.5), Vec3::new(1.5, 1.0, 1.5));
        assert_eq!(refitted.closest_point(q), fresh.closest_point(q), "{q}");
        assert_eq!(refitted.any_within(q, 0.05), fresh.any_within(q, 0.05), "{q}");
        let dir = Vec3::new(rng.random_range(-1.0..1.0), -1.0, rng.random_range(-1.0..1.0));
        let dir = dir.normalize();
        assert_eq!(refitted.ray_cast(q, dir, 0.0, 10.0), fresh.ray_cast(q, dir, 0.0, 10.0), "{q}");
    }
    // Corners above the shared vertices tie faces: the lowest face wins in both.
    for p in moved.positions.iter().step_by(7) {
        let q = *p + Vec3::Y * 0.02;
        assert_eq!(refitted.closest_point(q), fresh.closest_point(q), "{q}");
    }
    // Other faces get a fresh build.
    let other = TriMesh::new(moved.positions.clone(), moved.faces[..10].to_vec());
    assert_eq!(Bvh::build(&at_rest).refit(&other).num_triangles(), 10);
}

/// Faces of a triangle soup whose corners are listed in order.
fn tri_faces(n: usize) -> Vec<[u32; 3]> {
    (0..n as u32).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect()
}

/// A point drawn evenly in the box from `lo` to `hi` (x, then y, then z).
fn random_point(rng: &mut ChaCha8Rng, lo: Vec3, hi: Vec3) -> Vec3 {
    Vec3::new(
        rng.random_range(lo.x..hi.x),
        rng.random_range(lo.y..hi.y),
        rng.random_range(lo.z..hi.z),
    )
}

/// The far corner of the box around `bumpy_grid`'s unit sheet that the queries come from.
const SLAB_MAX: Vec3 = Vec3::new(1.5, 0.5, 1.5);
