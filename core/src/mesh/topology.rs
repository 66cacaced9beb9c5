//! Connectivity: connected components and clean-up of extracted meshes.

use super::TriMesh;

/// Label each face with its connected component (faces sharing a vertex are connected).
/// Returns (face labels, number of components).
pub fn face_components(mesh: &TriMesh) -> (Vec<u32>, usize) {
    let n = mesh.positions.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for &[a, b, c] in &mesh.faces {
        for (u, v) in [(a, b), (b, c)] {
            let (ru, rv) = (find(&mut parent, u), find(&mut parent, v));
            if ru != rv {
                parent[ru.max(rv) as usize] = ru.min(rv);
            }
        }
    }
    let mut label_of_root = vec![u32::MAX; n];
    let mut count = 0u32;
    let labels = mesh
        .faces
        .iter()
        .map(|&[a, _, _]| {
            let r = find(&mut parent, a) as usize;
            if label_of_root[r] == u32::MAX {
                label_of_root[r] = count;
                count += 1;
            }
            label_of_root[r]
        })
        .collect();
    (labels, count as usize)
}

/// Keep only the connected component with the most faces, dropping unused vertices.
pub fn largest_component(mesh: &TriMesh) -> TriMesh {
    let (labels, count) = face_components(mesh);
    if count <= 1 {
        return mesh.clone();
    }
    let mut sizes = vec![0usize; count];
    for &l in &labels {
        sizes[l as usize] += 1;
    }
    let best = (0..count).max_by_key(|&c| sizes[c]).unwrap_or(0) as u32;
    let faces: Vec<[u32; 3]> =
        mesh.faces.iter().zip(&labels).filter(|(_, l)| **l == best).map(|(f, _)| *f).collect();
    compact(&mesh.positions, &faces)
}

/// Drop vertices no face uses and renumber.
pub fn compact(positions: &[glam::Vec3], faces: &[[u32; 3]]) -> TriMesh {
    let mut remap = vec![u32::MAX; positions.len()];
    let mut kept = Vec::new();
    let faces = faces
        .iter()
        .map(|f| {
            f.map(|v| {
                if remap[v as usize] == u32::MAX {
                    remap[v as usize] = kept.len() as u32;
                    kept.push(positions[v as usize]);
                }
                remap[v as usize]
            })
        })
        .collect();
    TriMesh::new(kept, faces)
}

/// How many faces use each undirected edge (smaller vertex index first): 1 on an open border,
/// 2 inside a surface, 3 or more where it is non-manifold.
pub fn edge_use(faces: &[[u32; 3]]) -> std::collections::HashMap<(u32, u32), u32> {
    let mut uses = std::collections::HashMap::with_capacity(faces.len() * 3 / 2);
    for &[a, b, c] in faces {
        for (u, v) in [(a, b), (b, c), (c, a)] {
            *uses.entry((u.min(v), u.max(v))).or_insert(0) += 1;
        }
    }
    uses
}

/// Label each face with its piece, faces sharing an edge being connected (two sheets that
/// touch at a single vertex are two pieces). Returns (face labels, number of pieces).
pub fn edge_components(faces: &[[u32; 3]]) -> (Vec<u32>, usize) {
    let n = faces.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    let mut first_face: std::collections::HashMap<(u32, u32), u32> =
        std::collections::HashMap::with_capacity(n * 3 / 2);
    for (f, &[a, b, c]) in faces.iter().enumerate() {
        for (u, v) in [(a, b), (b, c), (c, a)] {
            let e = (u.min(v), u.max(v));
            match first_face.get(&e) {
                Some(&g) => {
                    let (rf, rg) = (find(&mut parent, f as u32), find(&mut parent, g));
                    if rf != rg {
                        parent[rf.max(rg) as usize] = rf.min(rg);
                    }
                }
                None => {
                    first_face.insert(e, f as u32);
                }
            }
        }
    }
    let mut label_of_root = vec![u32::MAX; n];
    let mut count = 0u32;
    let labels = (0..n as u32)
        .map(|f| {
            let r = find(&mut parent, f) as usize;
            if label_of_root[r] == u32::MAX {
                label_of_root[r] = count;
                count += 1;
            }
            label_of_root[r]
        })
        .collect();
    (labels, count as usize)
}

/// Drop the pieces (`edge_components`) with less area than `min_area` (square metres): shreds
/// hanging from a sheet by a vertex, specks. Unused vertices are dropped.
pub fn drop_small_pieces(mesh: &TriMesh, min_area: f32) -> TriMesh {
    let (labels, count) = edge_components(&mesh.faces);
    let mut area = vec![0f32; count];
    for (f, &l) in labels.iter().enumerate() {
        area[l as usize] += mesh.triangle_area(f);
    }
    if area.iter().all(|&a| a >= min_area) {
        return mesh.clone();
    }
    let faces: Vec<[u32; 3]> = mesh
        .faces
        .iter()
        .zip(&labels)
        .filter(|(_, l)| area[**l as usize] >= min_area)
        .map(|(f, _)| *f)
        .collect();
    compact(&mesh.positions, &faces)
}

/// A position as a hash key: bit-identical points (+0.0 and -0.0 alike) share one.
pub(crate) fn position_key(p: glam::Vec3) -> [u32; 3] {
    p.to_array().map(|c| (c + 0.0).to_bits())
}

/// Drop faces until no edge is used by more than two faces (vertices at bit-identical positions
/// count as one, as the integrity ruler counts them): on each such edge the two largest faces
/// stay, the first `keep_first` faces before any other (a wrapped body's own faces, which its
/// skinning finds by position in the list). A fin or a pinch left by hole filling, seam snapping or a marching-cubes ambiguity
/// becomes a small opening instead of an edge no exporter or modeller accepts. Vertices keep
/// their indices (callers that need it compact). Returns the mesh and how many faces went.
pub fn drop_non_manifold_faces(mesh: &TriMesh, keep_first: usize) -> (TriMesh, usize) {
    use std::collections::HashMap;
    let mut index_of: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
    let welded: Vec<u32> = mesh
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| *index_of.entry(position_key(*p)).or_insert(i as u32))
        .collect();
    let mut faces_of: HashMap<(u32, u32), Vec<u32>> =
        HashMap::with_capacity(mesh.faces.len() * 3 / 2);
    for (f, face) in mesh.faces.iter().enumerate() {
        let [a, b, c] = face.map(|v| welded[v as usize]);
        for (u, v) in [(a, b), (b, c), (c, a)] {
            if u != v {
                faces_of.entry((u.min(v), u.max(v))).or_default().push(f as u32);
            }
        }
    }
    let mut crowded: Vec<(&(u32, u32), &Vec<u32>)> =
        faces_of.iter().filter(|(_, faces)| faces.len() > 2).collect();
    if crowded.is_empty() {
        return (mesh.clone(), 0);
    }
    crowded.sort_unstable_by_key(|(edge, _)| **edge);
    let mut dropped = vec![false; mesh.faces.len()];
    for (_, faces) in crowded {
        let mut live: Vec<u32> = faces.iter().copied().filter(|&f| !dropped[f as usize]).collect();
        if live.len() <= 2 {
            continue;
        }
        let kept_first = |f: u32| (f as usize) < keep_first;
        live.sort_by(|&f, &g| {
            kept_first(g)
                .cmp(&kept_first(f))
                .then(mesh.triangle_area(g as usize).total_cmp(&mesh.triangle_area(f as usize)))
                .then(f.cmp(&g))
        });
        for &f in &live[2..] {
            dropped[f as usize] = true;
        }
    }
    let faces: Vec<[u32; 3]> =
        mesh.faces.iter().zip(&dropped).filter(|(_, d)| !**d).map(|(f, _)| *f).collect();
    let removed = mesh.faces.len() - faces.len();
    (TriMesh::new(mesh.positions.clone(), faces), removed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn largest_component_keeps_bigger_piece() {
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        // A two-triangle quad and a separate single triangle.
        positions.extend([Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)]);
        faces.extend([[0, 1, 2], [1, 3, 2]]);
        positions.extend([Vec3::splat(5.0), Vec3::new(6.0, 5.0, 5.0), Vec3::new(5.0, 6.0, 5.0)]);
        faces.push([4, 5, 6]);
        let mesh = TriMesh::new(positions, faces);
        assert_eq!(face_components(&mesh).1, 2);
        let big = largest_component(&mesh);
        assert_eq!(big.faces.len(), 2);
        assert_eq!(big.positions.len(), 4);
    }

    #[test]
    fn a_shred_hanging_by_a_vertex_is_its_own_piece_and_is_dropped() {
        // A 1 m square of two triangles, and a 1 cm triangle touching its corner (3) only.
        let positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.01, 1.0, 0.0),
            Vec3::new(1.0, 1.01, 0.0),
        ];
        let mesh = TriMesh::new(positions, vec![[0, 1, 2], [1, 3, 2], [3, 4, 5]]);
        assert_eq!(face_components(&mesh).1, 1);
        assert_eq!(edge_components(&mesh.faces).1, 2);
        let kept = drop_small_pieces(&mesh, 0.01);
        assert_eq!((kept.faces.len(), kept.positions.len()), (2, 4));
        assert_eq!(drop_small_pieces(&mesh, 1e-6), mesh);
    }

    #[test]
    fn a_fin_loses_its_smallest_face_and_split_vertices_count_as_one() {
        use crate::mesh::integrity::integrity;
        // Two faces of a 1 m square share the edge 1-2; a fin (a 1 cm triangle, then a large one
        // standing up) on the same edge makes it an edge of three or four faces.
        let positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.5, 0.5, 0.01),
            // The edge 1-2 again, as split vertices (bit-identical copies).
            Vec3::X,
            Vec3::Y,
            Vec3::new(0.5, 0.5, 2.0),
        ];
        let faces = vec![[0, 1, 2], [1, 3, 2], [1, 2, 4], [5, 6, 7]];
        let mesh = TriMesh::new(positions, faces);
        assert_eq!(integrity(&mesh).non_manifold_edges, 1);
        let (clean, removed) = drop_non_manifold_faces(&mesh, 0);
        assert_eq!(removed, 2);
        // The two largest stay: the upright 2 m fin and one of the square's halves (0.5 m^2
        // each; the tie goes to the lower index).
        assert_eq!(clean.faces, vec![[0, 1, 2], [5, 6, 7]]);
        assert_eq!(integrity(&clean).non_manifold_edges, 0);
        assert_eq!(clean.positions, mesh.positions);
        // A manifold mesh is returned as it is.
        let square = TriMesh::new(mesh.positions[..4].to_vec(), vec![[0, 1, 2], [1, 3, 2]]);
        assert_eq!(drop_non_manifold_faces(&square, 0), (square.clone(), 0));
        // Faces kept first stay whatever their size: the square, and the fin goes.
        let (kept, _) = drop_non_manifold_faces(&mesh, 2);
        assert_eq!(kept.faces, vec![[0, 1, 2], [1, 3, 2]]);
    }
}
