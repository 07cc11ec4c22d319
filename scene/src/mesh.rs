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

    /// Rejects a mesh that would render as nothing: one whose triangles' vertices are all at one
    /// point ([`SceneError::ZeroSize`]), or whose triangles all have zero area
    /// ([`SceneError::AllDegenerate`]). Zero area is judged at `f32` precision at the mesh's
    /// scale, since that is what the renderer sees: twice the area, in `f64`, at most
    /// `(f32::EPSILON · diagonal)²`. Some degenerate triangles among visible ones are harmless
    /// (rays never hit them) and kept. `source` names the file in errors.
    pub fn check_visible(&self, source: &Path) -> Result<(), SceneError> {
        if self.indices.is_empty() {
            return Err(SceneError::NoTriangles {
                path: source.to_path_buf(),
            });
        }
        // In f64 (glam is built without its f64 types here): no overflow for f32 inputs.
        let corner = |i: u32| self.positions[i as usize].to_array().map(f64::from);
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in self.indices.iter().flatten().map(|&i| corner(i)) {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let diagonal = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
        if diagonal == 0.0 {
            return Err(SceneError::ZeroSize {
                path: source.to_path_buf(),
            });
        }
        // Finite coordinates whose extent overflows f32 would turn into infinities (and NaN
        // triangles) as soon as the scene is framed or transformed.
        if diagonal > f32::MAX as f64 / 4.0 {
            return Err(SceneError::InvalidGeometry {
                path: source.to_path_buf(),
                message: format!("the mesh's extent ({diagonal:.3e}) overflows f32 arithmetic"),
            });
        }
        let tiny = (f32::EPSILON as f64 * diagonal).powi(2);
        let visible = self.indices.iter().any(|t| {
            let [a, b, c] = t.map(corner);
            let (u, v) = (
                [0, 1, 2].map(|k| b[k] - a[k]),
                [0, 1, 2].map(|k| c[k] - a[k]),
            );
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            n.iter().map(|x| x * x).sum::<f64>().sqrt() > tiny
        });
        if visible {
            Ok(())
        } else {
            Err(SceneError::AllDegenerate {
                path: source.to_path_buf(),
                triangles: self.indices.len(),
            })
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
    fn invisible_meshes_are_rejected() {
        let p = Path::new("flat.obj");
        let mesh =
            |positions: Vec<Vec3>, indices| Mesh::new(p, positions, vec![], indices).unwrap();
        let point = mesh(vec![Vec3::ONE; 3], vec![[0, 1, 2]]);
        assert!(matches!(
            point.check_visible(p),
            Err(SceneError::ZeroSize { .. })
        ));
        // Collinear triangles, and one far too thin for f32 at this scale.
        let line = mesh(
            vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::X * 2.0,
                Vec3::new(1e3, 1e-9, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 1], [0, 3, 2]],
        );
        let e = line.check_visible(p).unwrap_err();
        assert!(
            matches!(e, SceneError::AllDegenerate { triangles: 3, .. }),
            "{e}"
        );
        assert!(
            e.to_string()
                .contains("flat.obj: all 3 triangles are degenerate"),
            "{e}"
        );
        // One visible triangle among degenerate ones is enough; so is a tiny but whole mesh.
        let some = mesh(
            vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::Y],
            vec![[0, 1, 2], [0, 1, 3]],
        );
        assert!(some.check_visible(p).is_ok());
        let tiny = mesh(
            vec![Vec3::ZERO, Vec3::X * 1e-30, Vec3::Y * 1e-30],
            vec![[0, 1, 2]],
        );
        assert!(tiny.check_visible(p).is_ok());
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
