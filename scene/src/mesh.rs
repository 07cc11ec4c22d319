//! An indexed triangle mesh in object space, validated once so the rest of the pipeline can trust
//! it: finite positions, indices in range, at least one triangle, one unit normal per vertex.

use crate::error::SceneError;
use std::path::Path;
use vrrt_core::glam::{Affine3A, Mat3, Vec3};

/// Indexed triangles with per-vertex shading normals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Unit shading normal per vertex (same length as `positions`).
    pub normals: Vec<Vec3>,
    /// Triangles as vertex index triples, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    /// Validates raw geometry. `normals` may be empty (smooth normals are computed) or one per
    /// vertex; zero or non-finite normals are replaced by computed ones. `source` names the file in
    /// errors.
    pub fn new(
        source: &Path,
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
    ) -> Result<Mesh, SceneError> {
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::geometry(
                source,
                format!("vertex {i} is not finite ({})", positions[i]),
            ));
        }
        let n = positions.len();
        if let Some((t, tri)) = indices
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&i| i as usize >= n))
        {
            return Err(SceneError::geometry(
                source,
                format!("triangle {t} uses vertex {tri:?}, but there are only {n} vertices"),
            ));
        }
        if indices.is_empty() {
            return Err(SceneError::NoTriangles {
                path: source.to_path_buf(),
            });
        }
        if !normals.is_empty() && normals.len() != n {
            return Err(SceneError::geometry(
                source,
                format!("{} normals for {n} vertices", normals.len()),
            ));
        }
        let mut mesh = Mesh {
            positions,
            normals,
            indices,
        };
        mesh.repair_normals();
        Ok(mesh)
    }

    /// Fills missing or unusable normals with area-weighted smooth normals (or +Y where even
    /// those vanish, e.g. vertices used only by degenerate triangles).
    fn repair_normals(&mut self) {
        let smooth = smooth_normals(&self.positions, &self.indices);
        if self.normals.len() != self.positions.len() {
            self.normals = smooth;
            return;
        }
        for (n, s) in self.normals.iter_mut().zip(smooth) {
            let len = n.length();
            *n = if len.is_finite() && len > 1e-20 {
                *n / len
            } else {
                s
            };
        }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Appends `other`'s triangles.
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.indices.extend(
            other
                .indices
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }

    /// The mesh with `m` applied (normals by the inverse transpose; winding flipped for mirroring
    /// maps so front faces stay counter-clockwise).
    pub fn transformed(&self, m: &Affine3A) -> Mesh {
        let normal_matrix = normal_matrix(m);
        let flip = Mat3::from(m.matrix3).determinant() < 0.0;
        Mesh {
            positions: self
                .positions
                .iter()
                .map(|&p| m.transform_point3(p))
                .collect(),
            normals: self
                .normals
                .iter()
                .map(|&n| (normal_matrix * n).normalize_or(Vec3::Y))
                .collect(),
            indices: if flip {
                self.indices.iter().map(|t| [t[0], t[2], t[1]]).collect()
            } else {
                self.indices.clone()
            },
        }
    }

    /// Axis-aligned bounds `(min, max)`; `(0, 0)` for an empty mesh.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        if self.positions.is_empty() {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        self.positions.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    }
}

/// Inverse transpose of the linear part (identity when singular).
pub fn normal_matrix(m: &Affine3A) -> Mat3 {
    let l = Mat3::from(m.matrix3);
    if l.determinant().abs() < 1e-30 {
        Mat3::IDENTITY
    } else {
        l.inverse().transpose()
    }
}

/// Area-weighted vertex normals (the unnormalized cross product weighs by area).
pub fn smooth_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    for t in indices {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            acc[i as usize] += n;
        }
    }
    acc.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_geometry_with_the_file_name() {
        let p = Path::new("bad.obj");
        let err = Mesh::new(p, vec![Vec3::NAN], vec![], vec![[0, 0, 0]]).unwrap_err();
        assert!(
            err.to_string().contains("bad.obj") && err.to_string().contains("not finite"),
            "{err}"
        );
        let err = Mesh::new(p, vec![Vec3::ZERO], vec![], vec![[0, 1, 0]]).unwrap_err();
        assert!(err.to_string().contains("only 1 vertices"), "{err}");
        let err = Mesh::new(p, vec![Vec3::ZERO], vec![], vec![]).unwrap_err();
        assert!(matches!(err, SceneError::NoTriangles { .. }));
    }

    #[test]
    fn computes_and_repairs_normals() {
        let p = Path::new("t");
        let pos = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let m = Mesh::new(p, pos.clone(), vec![], vec![[0, 1, 2]]).unwrap();
        assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
        let m = Mesh::new(
            p,
            pos,
            vec![Vec3::ZERO, Vec3::X * 2.0, Vec3::NAN],
            vec![[0, 1, 2]],
        )
        .unwrap();
        assert_eq!(m.normals, vec![Vec3::Z, Vec3::X, Vec3::Z]);
        let mirrored = m.transformed(&Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        assert_eq!(mirrored.indices, vec![[0, 2, 1]]);
    }
}
