use super::*;
use crate::mesh::extract::{ExtractOptions, extract};
use crate::mesh::holes::{border_loops, loop_length};
use crate::mesh::integrity::integrity;
use glam::Vec2;

/// A capsule standing on the y axis (radius 10 cm, from y = -0.6 to 0.6): the body.
fn body() -> TriMesh {
    let capsule = |p: &Vec3| {
        let y = p.y.clamp(-0.5, 0.5);
        (*p - Vec3::new(0.0, y, 0.0)).length() - 0.1
    };
    let opts = ExtractOptions::new(Vec3::new(-0.2, -0.7, -0.2), Vec3::new(0.2, 0.7, 0.2), 48);
    extract(|ps: &[Vec3]| ps.iter().map(capsule).collect(), &opts).unwrap().mesh
}

/// A flared skirt round the capsule: a cone from 12 cm at y = 0.2 to 25 cm at y = -0.3.
fn skirt_radius(y: f32) -> f32 {
    0.12 + (0.2 - y) * 0.26
}

fn radial(p: &Vec3) -> f32 {
    Vec2::new(p.x, p.z).length()
}

/// Farther than 1.5 cm from the capsule.
fn loose(p: Vec3) -> bool {
    radial(&p) > 0.115
}

/// The skirt as a slab `thickness` thick (its outer side on the cone), with or without a hole
/// of 4 cm radius through its front (+z) at y = -0.05.
fn skirt_sdf(thickness: f32, hole: bool) -> impl Fn(&Vec3) -> f32 + Copy {
    move |p: &Vec3| {
        let r = skirt_radius(p.y.clamp(-0.3, 0.2));
        let slab = (radial(p) - (r - 0.5 * thickness)).abs() - 0.5 * thickness;
        let bounded = slab.max(p.y - 0.2).max(-0.3 - p.y);
        let hole_centre = Vec3::new(0.0, -0.05, skirt_radius(-0.05));
        if hole { bounded.max(0.04 - (*p - hole_centre).length()) } else { bounded }
    }
}

fn extracted(sdf: impl Fn(&Vec3) -> f32 + Sync, cells: usize) -> TriMesh {
    let opts =
        ExtractOptions::new(Vec3::new(-0.35, -0.4, -0.35), Vec3::new(0.35, 0.3, 0.35), cells);
    extract(|ps: &[Vec3]| ps.iter().map(&sdf).collect(), &opts).unwrap().mesh
}

#[test]
fn a_holed_skirt_comes_out_one_whole_sheet_on_its_cone() {
    let sheet = GarmentSheet::around(&body(), SheetGridOptions::default());
    let sdf = skirt_sdf(0.02, true);
    // 2 cm of cloth on 1.5 cm cells, with a hole through its front: a closed slab, whose
    // inner wall the sheet hides.
    let pieces = extracted(sdf, 48);
    let torn = integrity(&pieces);
    let remade = sheet.remesh(&pieces, |ps| ps.iter().map(sdf).collect(), loose);
    let whole = integrity(&remade);
    assert_eq!(whole.pieces, 1, "extracted: {torn:?}, remade: {whole:?}");
    assert_eq!(whole.non_manifold_edges, 0);
    // Its border is the waist and the hem, nothing else.
    let loops = border_loops(&remade);
    assert_eq!(
        loops.len(),
        2,
        "border loops {:?}",
        loops.iter().map(|l| loop_length(&remade, l)).collect::<Vec<_>>()
    );
    let truth = TAU * (skirt_radius(0.2) + skirt_radius(-0.3));
    assert!(
        whole.boundary_length_m < 1.25 * truth && whole.boundary_length_m > 0.8 * truth,
        "border {} m, the waist and the hem {truth} m",
        whole.boundary_length_m
    );
    // Every vertex lies on the cloth, the hole's included: the outside, the membrane across the
    // hole (the cone there), or at the hole's rim its wall (within the slab's 2 cm).
    for p in &remade.positions {
        let off = radial(p) - skirt_radius(p.y.clamp(-0.3, 0.2));
        assert!(off > -0.023 && off < 0.004, "{p} is {off} m off the cone");
    }
    let hole = Vec3::new(0.0, -0.05, skirt_radius(-0.05));
    assert!(remade.positions.iter().any(|p| p.distance(hole) < 0.01), "the hole stays open");
}

#[test]
fn the_sheet_faces_out_and_has_even_triangles() {
    let sheet = GarmentSheet::around(&body(), SheetGridOptions::default());
    let sdf = skirt_sdf(0.02, false);
    let remade = sheet.remesh(&extracted(sdf, 64), |ps| ps.iter().map(sdf).collect(), loose);
    assert!(remade.signed_volume().is_finite());
    let normals = remade.face_normals();
    for (f, n) in normals.iter().enumerate() {
        let [a, b, c] = remade.triangle(f);
        let centre = (a + b + c) / 3.0;
        let out = Vec3::new(centre.x, 0.0, centre.z).normalize();
        assert!(n.dot(out) > 0.5, "face {f} faces {n}");
    }
    let longest = remade
        .faces
        .iter()
        .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
        .map(|(u, v)| remade.positions[u as usize].distance(remade.positions[v as usize]))
        .fold(0f32, f32::max);
    assert!(longest < 0.025, "an edge of {longest} m");
}

#[test]
fn pieces_no_ray_reaches_first_are_kept_as_they_were() {
    let sheet = GarmentSheet::around(&body(), SheetGridOptions::default());
    // A flat brim round the capsule at y = 0.3 (3 cm thick, out to 30 cm): rays run along it,
    // never into its face, so it is kept; and the skirt below it.
    let skirt = skirt_sdf(0.02, false);
    let brim = |p: &Vec3| (p.y - 0.3).abs().max(radial(p) - 0.3).max(0.1 - radial(p)) - 0.015;
    let sdf = move |p: &Vec3| skirt(p).min(brim(p));
    // Extracted apart (an extraction keeps its largest piece) and put together.
    let mut pieces = extracted(skirt, 64);
    let opts = ExtractOptions::new(Vec3::new(-0.35, 0.2, -0.35), Vec3::new(0.35, 0.4, 0.35), 64);
    let brim_mesh = extract(|ps: &[Vec3]| ps.iter().map(brim).collect(), &opts).unwrap().mesh;
    let base = pieces.positions.len() as u32;
    pieces.positions.extend(brim_mesh.positions);
    pieces.faces.extend(brim_mesh.faces.iter().map(|f| f.map(|v| v + base)));
    let remade = sheet.remesh(&pieces, |ps| ps.iter().map(sdf).collect(), loose);
    let on_brim =
        remade.positions.iter().filter(|p| (p.y - 0.3).abs() < 0.02 && radial(p) > 0.2).count();
    assert!(on_brim > 50, "{on_brim} vertices on the brim");
    assert!(
        remade.positions.iter().any(|p| p.y < -0.25 && radial(p) > 0.24),
        "the skirt's hem is gone"
    );
}

#[test]
fn the_grid_fills_holes_and_keeps_open_space() {
    use grid::*;
    let shape = Shape { rows: 6, columns: 8 };
    // Cloth on rows 1-4 with a two-cell hole at column 3; row 0 is the open space below the
    // hem, row 5 above the waist.
    let mut mask = vec![false; shape.len()];
    for r in 1..5 {
        for c in 0..8 {
            mask[shape.index(r, c)] = true;
        }
    }
    mask[shape.index(2, 3)] = false;
    mask[shape.index(3, 3)] = false;
    let filled = fill_enclosed(shape, &mask);
    assert!(filled[shape.index(2, 3)] && filled[shape.index(3, 3)]);
    assert!(!filled[shape.index(0, 3)] && !filled[shape.index(5, 3)]);
    // The column wraps: cell (2, 7) neighbours (2, 0).
    assert!(shape.neighbours(shape.index(2, 7)).any(|n| n == shape.index(2, 0)));
    // Values across the hole: a membrane between known rows 1 and 4.
    let known: Vec<Option<f32>> = (0..shape.len())
        .map(|i| (filled[i] && mask[i]).then(|| (i / shape.columns) as f32))
        .collect();
    let value = fill_values(shape, &filled, &known, 200);
    assert!((value[shape.index(2, 3)].unwrap() - 2.0).abs() < 0.05);
    assert!((value[shape.index(3, 3)].unwrap() - 3.0).abs() < 0.05);
}

#[test]
fn short_tears_close_in_columns_and_rows_and_wide_openings_stay() {
    use grid::*;
    let shape = Shape { rows: 12, columns: 8 };
    let cloth = |cells: &[(usize, usize)]| {
        let mut mask = vec![false; shape.len()];
        for &(r, c) in cells {
            mask[shape.index(r, c)] = true;
        }
        mask
    };
    // Column 2: cloth on rows 1-3 and 7-9, a gap of three rows between.
    let column: Vec<(usize, usize)> = [1, 2, 3, 7, 8, 9].iter().map(|&r| (r, 2)).collect();
    let mask = cloth(&column);
    let filled = fill_short_gaps(shape, &mask, 3, 0);
    assert!((4..7).all(|r| filled[shape.index(r, 2)]));
    assert!(!filled[shape.index(0, 2)] && !filled[shape.index(10, 2)], "nothing past the ends");
    assert_eq!(fill_short_gaps(shape, &mask, 2, 0), mask, "a longer gap stays");
    // Row 5: cloth on columns 0-1 and 5-7: a gap of three columns, none across the wrap.
    let row: Vec<(usize, usize)> = [0, 1, 5, 6, 7].iter().map(|&c| (5, c)).collect();
    let mask = cloth(&row);
    let filled = fill_short_gaps(shape, &mask, 0, 3);
    assert!((0..8).all(|c| filled[shape.index(5, c)]));
    assert_eq!(fill_short_gaps(shape, &mask, 0, 2), mask, "a wider gap stays");
    // Row 6: cloth on columns 6, 7 and 0 (across the wrap): the five columns 1-5 are an
    // opening wider than three.
    let mask = cloth(&[(6, 6), (6, 7), (6, 0)]);
    assert_eq!(fill_short_gaps(shape, &mask, 0, 3), mask);
}

/// The cone's skirt with a slit `width` radians wide through its front, from the hem up to
/// `top` (y).
fn slit_skirt_sdf(width: f32, top: f32) -> impl Fn(&Vec3) -> f32 + Copy {
    let skirt = skirt_sdf(0.02, false);
    move |p: &Vec3| {
        // Angular distance from the front (+z), as an arc on the cone (metres).
        let angle = p.x.atan2(p.z).abs();
        let r = skirt_radius(p.y.clamp(-0.3, 0.2));
        let slit = ((0.5 * width - angle) * r).min(top - p.y);
        skirt(p).max(slit)
    }
}

#[test]
fn a_skirt_torn_up_from_its_hem_comes_out_whole_and_a_cape_stays_open() {
    let sheet = GarmentSheet::around(&body(), SheetGridOptions::default());
    let truth = TAU * (skirt_radius(0.2) + skirt_radius(-0.3));
    let remade = |sheet: &GarmentSheet, sdf: &(dyn Fn(&Vec3) -> f32 + Sync)| {
        let pieces = extracted(|p: &Vec3| sdf(p), 48);
        sheet.remesh(&pieces, |ps| ps.iter().map(sdf).collect(), loose)
    };
    // A tear 20 degrees wide (7 cm at the hem) from the hem up 35 cm: the rays see open space
    // that reaches the hem, which only the short-gap rule closes.
    let slit = slit_skirt_sdf(20f32.to_radians(), 0.05);
    let whole = integrity(&remade(&sheet, &slit));
    assert_eq!(whole.pieces, 1, "{whole:?}");
    assert!(
        whole.boundary_length_m < 1.25 * truth,
        "border {} m, the waist and the hem {truth} m",
        whole.boundary_length_m
    );
    let mut as_seen = sheet.clone();
    (as_seen.options.gap_rows, as_seen.options.gap_columns) = (0, 0);
    let torn = integrity(&remade(&as_seen, &slit));
    assert!(
        torn.boundary_length_m > whole.boundary_length_m + 0.5,
        "without the rule the tear's two edges stay borders: {} against {} m",
        torn.boundary_length_m,
        whole.boundary_length_m
    );
    // A cape: the front's 120 degrees open all the way up. Its two front edges stay borders.
    let cape = remade(&sheet, &slit_skirt_sdf(120f32.to_radians(), 0.3));
    let open = integrity(&cape);
    let edges = 2.0 * 0.5;
    let rim = (1.0 - 120.0 / 360.0) * truth;
    assert!(
        open.boundary_length_m > 0.9 * (rim + edges),
        "cape border {} m, its waist, hem and front edges {} m",
        open.boundary_length_m,
        rim + edges
    );
    let front = Vec3::new(0.0, -0.1, skirt_radius(-0.1));
    assert!(
        cape.positions.iter().all(|p| p.distance(front) > 0.1),
        "cloth across the cape's front"
    );
}

#[test]
fn a_slanted_hem_comes_out_a_smooth_curve_not_a_staircase() {
    // The skirt's hem slants 16 cm from back to front (as a hem does over a raised knee): on
    // the grid's 1 cm rows it is a staircase until the border is smoothed.
    let hem = |p: &Vec3| -0.3 + 0.08 * p.z.atan2(p.x).sin();
    let sdf = move |p: &Vec3| {
        let r = skirt_radius(p.y.clamp(-0.38, 0.2));
        let slab = (radial(p) - (r - 0.01)).abs() - 0.01;
        slab.max(p.y - 0.2).max(hem(p) - p.y)
    };
    let pieces = extracted(sdf, 64);
    let length = |m: &TriMesh| border_loops(m).iter().map(|l| loop_length(m, l)).sum::<f32>();
    // The truth: the waist's circle and the hem's curve, summed over 3,600 steps.
    let hem_point = |t: f32| {
        let (s, c) = t.sin_cos();
        let y = -0.3 + 0.08 * s;
        Vec3::new(c * skirt_radius(y), y, s * skirt_radius(y))
    };
    let steps = 3600;
    let hem_length: f32 = (0..steps)
        .map(|i| {
            let t = |k: usize| TAU * k as f32 / steps as f32;
            hem_point(t(i)).distance(hem_point(t(i + 1)))
        })
        .sum();
    let truth = TAU * skirt_radius(0.2) + hem_length;
    let sheet_with = |iterations: usize, radius_smoothing: usize| {
        let options = SheetGridOptions {
            border_smoothing: iterations,
            radius_smoothing,
            ..Default::default()
        };
        let sheet = GarmentSheet::around(&body(), options);
        sheet.remesh(&pieces, |ps| ps.iter().map(sdf).collect(), loose)
    };
    let radius_smoothing = SheetGridOptions::default().radius_smoothing;
    let (stepped, smoothed) =
        (length(&sheet_with(0, 0)), length(&sheet_with(10, radius_smoothing)));
    // Without smoothing (the border's and the radius's) 2.58 m, 1.09x the truth's 2.37 m.
    assert!(smoothed < 1.03 * truth, "border {stepped} -> {smoothed} m, truth {truth} m");
    assert!(smoothed < stepped - 0.1, "border {stepped} -> {smoothed} m");
    assert_eq!(integrity(&sheet_with(10, radius_smoothing)).pieces, 1);
}

#[test]
fn the_hem_loses_its_tongues_and_notches_and_keeps_a_wide_step() {
    use grid::even_hem;
    // Cloth from row 10 up, except a tongue (3 columns down to row 4), a notch (2 columns
    // ending at row 14) and a step 20 columns wide down to row 6 (a longer back panel).
    let shape = Shape { rows: 30, columns: 90 };
    let bottom_of = |c: usize| match c {
        10..=12 => 4,
        30..=31 => 14,
        50..=69 => 6,
        _ => 10,
    };
    let mut mask: Vec<bool> =
        (0..shape.len()).map(|i| i / shape.columns >= bottom_of(i % shape.columns)).collect();
    // The radius grows by a centimetre a row, so a filled notch's radius can be checked.
    let mut radius: Vec<Option<f32>> = (0..shape.len())
        .map(|i| mask[i].then(|| 0.3 + 0.01 * (i / shape.columns) as f32))
        .collect();
    even_hem(shape, &mut mask, &mut radius, 4);
    let bottom = |c: usize| (0..shape.rows).find(|&r| mask[shape.index(r, c)]).unwrap();
    for c in [10, 11, 12, 30, 31, 0, 40, 89] {
        assert_eq!(bottom(c), 10, "column {c}");
    }
    for c in 55..=64 {
        assert_eq!(bottom(c), 6, "the wide step stays (column {c})");
    }
    // The notch is filled with its rows' radius from the neighbours; no cell above the hem
    // changed.
    assert!((radius[shape.index(10, 30)].unwrap() - 0.40).abs() < 1e-6);
    for c in 0..shape.columns {
        for r in 15..shape.rows {
            assert!(mask[shape.index(r, c)] && radius[shape.index(r, c)].is_some());
        }
    }
}

#[test]
fn smoothing_flattens_a_lump_and_keeps_a_cone_to_its_borders() {
    use grid::smooth_values;
    // Cloth on rows 5..25 of 60 columns, its radius growing 2.6 mm a row (a flared skirt's
    // cone), with a 2 cm lump on one cell and a 1 cm one on two cells beside each other.
    let shape = Shape { rows: 30, columns: 60 };
    let cone = |i: usize| 0.2 + 0.0026 * (i / shape.columns) as f32;
    let mask: Vec<bool> =
        (0..shape.len()).map(|i| (5..25).contains(&(i / shape.columns))).collect();
    let mut radius: Vec<Option<f32>> = (0..shape.len()).map(|i| mask[i].then(|| cone(i))).collect();
    let lump = shape.index(15, 20);
    radius[lump] = radius[lump].map(|r| r + 0.02);
    for c in [40, 41] {
        let i = shape.index(10, c);
        radius[i] = radius[i].map(|r| r + 0.01);
    }
    smooth_values(shape, &mask, &mut radius, 30);
    assert!(
        radius[lump].unwrap() - cone(lump) < 0.002,
        "the lump {}",
        radius[lump].unwrap() - cone(lump)
    );
    let i = shape.index(10, 40);
    assert!(radius[i].unwrap() - cone(i) < 0.002);
    // Away from the lumps the cone stays to the bit's rounding, the waist and hem rows too.
    for c in [0, 5, 55] {
        for r in [5, 6, 12, 23, 24] {
            let i = shape.index(r, c);
            assert!((radius[i].unwrap() - cone(i)).abs() < 1e-5, "row {r} column {c}");
        }
    }
    // Cells without cloth stay without a value.
    assert!(radius[shape.index(2, 3)].is_none() && radius[shape.index(27, 3)].is_none());
}
