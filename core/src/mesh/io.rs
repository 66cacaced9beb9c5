//! Mesh and point-cloud files: OBJ and binary PLY, written atomically.

use super::{PointCloud, TriMesh};
use crate::error::{Error, Result};
use crate::io::write_atomic;
use glam::Vec3;
use std::io::Write;
use std::path::Path;

/// Write a mesh as OBJ (with vertex normals) or binary PLY, chosen by the extension.
pub fn write_mesh(path: impl AsRef<Path>, mesh: &TriMesh) -> Result<()> {
    let path = path.as_ref();
    match extension(path).as_str() {
        "obj" => write_obj(path, mesh),
        "ply" => write_ply(path, &mesh.positions, &mesh.vertex_normals(), &mesh.faces),
        other => {
            Err(Error::file(path, format!("unknown mesh format '.{other}' (use .obj or .ply)")))
        }
    }
}

pub fn write_obj(path: impl AsRef<Path>, mesh: &TriMesh) -> Result<()> {
    let normals = mesh.vertex_normals();
    write_atomic(path, |w| {
        writeln!(
            w,
            "# Avatar Studio mesh: {} vertices, {} faces",
            mesh.positions.len(),
            mesh.faces.len()
        )?;
        for p in &mesh.positions {
            writeln!(w, "v {:.6} {:.6} {:.6}", p.x, p.y, p.z)?;
        }
        for n in &normals {
            writeln!(w, "vn {:.5} {:.5} {:.5}", n.x, n.y, n.z)?;
        }
        for f in &mesh.faces {
            let [a, b, c] = f.map(|i| i + 1);
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        Ok(())
    })
}

/// Binary little-endian PLY with optional normals and faces.
pub fn write_ply(
    path: impl AsRef<Path>,
    points: &[Vec3],
    normals: &[Vec3],
    faces: &[[u32; 3]],
) -> Result<()> {
    let has_normals = !normals.is_empty() && normals.len() == points.len();
    write_atomic(path, |w| {
        writeln!(w, "ply\nformat binary_little_endian 1.0\ncomment Avatar Studio")?;
        writeln!(w, "element vertex {}", points.len())?;
        writeln!(w, "property float x\nproperty float y\nproperty float z")?;
        if has_normals {
            writeln!(w, "property float nx\nproperty float ny\nproperty float nz")?;
        }
        if !faces.is_empty() {
            writeln!(w, "element face {}\nproperty list uchar uint vertex_indices", faces.len())?;
        }
        writeln!(w, "end_header")?;
        for (i, p) in points.iter().enumerate() {
            for v in p.to_array() {
                w.write_all(&v.to_le_bytes())?;
            }
            if has_normals {
                for v in normals[i].to_array() {
                    w.write_all(&v.to_le_bytes())?;
                }
            }
        }
        for f in faces {
            w.write_all(&[3u8])?;
            for v in f {
                w.write_all(&v.to_le_bytes())?;
            }
        }
        Ok(())
    })
}

pub fn write_point_cloud(path: impl AsRef<Path>, cloud: &PointCloud) -> Result<()> {
    write_ply(path, &cloud.points, &cloud.normals, &[])
}

/// Read an OBJ's positions and faces (polygons are fan-triangulated).
pub fn read_obj(path: impl AsRef<Path>) -> Result<TriMesh> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_obj(&text).map_err(|msg| Error::file(path, msg))
}

fn parse_obj(text: &str) -> std::result::Result<TriMesh, String> {
    let mut mesh = TriMesh::default();
    for (line_no, line) in text.lines().enumerate() {
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => {
                let c: Vec<f32> = parts
                    .take(3)
                    .map(|s| s.parse::<f32>())
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|e| format!("line {}: bad vertex ({e})", line_no + 1))?;
                if c.len() != 3 || c.iter().any(|x| !x.is_finite()) {
                    return Err(format!("line {}: vertex needs 3 finite numbers", line_no + 1));
                }
                mesh.positions.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<u32> = parts
                    .map(|s| {
                        let first = s.split('/').next().unwrap_or("");
                        let i: i64 = first
                            .parse()
                            .map_err(|_| format!("line {}: bad face index '{s}'", line_no + 1))?;
                        let n = mesh.positions.len() as i64;
                        let i = if i < 0 { n + i } else { i - 1 };
                        if i < 0 || i >= n {
                            return Err(format!(
                                "line {}: face index {s} out of range",
                                line_no + 1
                            ));
                        }
                        Ok(i as u32)
                    })
                    .collect::<std::result::Result<_, _>>()?;
                if idx.len() < 3 {
                    return Err(format!("line {}: face with fewer than 3 vertices", line_no + 1));
                }
                for k in 1..idx.len() - 1 {
                    mesh.faces.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok(mesh)
}

fn extension(path: &Path) -> String {
    path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_round_trip_and_bad_index_named() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = TriMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        let path = dir.path().join("t.obj");
        write_mesh(&path, &mesh).unwrap();
        let back = read_obj(&path).unwrap();
        assert_eq!(back.faces, mesh.faces);
        assert!(back.positions.iter().zip(&mesh.positions).all(|(a, b)| (*a - *b).length() < 1e-6));
        std::fs::write(&path, "v 0 0 0\nf 1 2 3\n").unwrap();
        let err = read_obj(&path).unwrap_err().to_string();
        assert!(err.contains("t.obj") && err.contains("line 2"), "{err}");
    }

    #[test]
    fn ply_header_counts() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.ply");
        write_ply(&path, &[Vec3::ZERO, Vec3::X], &[Vec3::Y, Vec3::Y], &[]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let header = String::from_utf8_lossy(&bytes[..200.min(bytes.len())]);
        assert!(header.contains("element vertex 2") && header.contains("property float nx"));
        let body_len = bytes.len() - (header.find("end_header\n").unwrap() + 11);
        assert_eq!(body_len, 2 * 6 * 4);
    }
}
