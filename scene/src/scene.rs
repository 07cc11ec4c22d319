//! A scene: meshes, animated instances, a camera path and area lights; and [`Scene::frame`], which
//! evaluates everything the GPU needs for one frame.
//!
//! Per frame the instances are transformed to world space, merged into one triangle set and a BVH
//! is built over it (scenes whose instances never move build it once and share it). Motion vectors
//! come from a per-instance current→previous transform ([`InstanceData`]) and the previous frame's
//! camera.

use crate::animation::{CameraPath, Light, Trajectory};
use crate::bvh::{self, Bvh};
use crate::error::SceneError;
use crate::mesh::{normal_matrix, Mesh};
use std::sync::{Arc, OnceLock};
use vrrt_core::camera::Camera;
use vrrt_core::glam::{Affine3A, Mat3, Vec3};
use vrrt_core::kernels::gbuffer::{GbufferParams, InstanceData};
use vrrt_core::kernels::raygen::AreaLight;
use vrrt_core::trace::{Triangle, TriangleNormals};

/// Most lights a scene may have: one signal plane each, and kernels stack at most 4 planes.
pub const MAX_LIGHTS: usize = 4;

/// A placed, possibly moving, copy of a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Name, for debugging and overlays.
    pub name: String,
    /// Index into [`Scene::meshes`].
    pub mesh: usize,
    /// Object-to-world transform over time.
    pub motion: Trajectory,
    /// GGX alpha of the surface (1 = diffuse).
    pub roughness: f32,
}

/// Everything one frame needs on the GPU side.
#[derive(Clone, Debug)]
pub struct FrameGeometry {
    /// Frame number.
    pub index: u32,
    /// Time in seconds (`index / fps`).
    pub time: f32,
    /// Triangles, normals and BVH (shared between frames when the geometry is static).
    pub geometry: Arc<Bvh>,
    /// Per-instance data, indexed by [`Triangle::instance`].
    pub instances: Vec<InstanceData>,
    /// This frame's camera.
    pub camera: Camera,
    /// Last frame's camera (this frame's on frame 0).
    pub prev_camera: Camera,
    /// Area lights at this frame, one per shadow signal plane.
    pub lights: Vec<AreaLight>,
    /// A camera cut happened since the previous frame: history should be dropped.
    pub camera_cut: bool,
}

impl FrameGeometry {
    /// Push constants of the G-buffer pass at a resolution.
    pub fn gbuffer_params(&self, width: u32, height: u32) -> GbufferParams {
        GbufferParams {
            width,
            height,
            camera: self.camera,
            prev_camera: self.prev_camera,
        }
    }
}

/// A scene description.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Short name (the registry key of built-ins).
    pub name: String,
    /// What the scene is for.
    pub description: String,
    /// Object-space meshes.
    pub meshes: Vec<Mesh>,
    /// Placed meshes.
    pub instances: Vec<Instance>,
    /// The camera.
    pub camera: CameraPath,
    /// Area lights (at most [`MAX_LIGHTS`]).
    pub lights: Vec<Light>,
    /// Frames per second of the animation.
    pub fps: f32,
    /// Length of the sequence in frames.
    pub frame_count: u32,
    static_geometry: OnceLock<Arc<Bvh>>,
}

impl Scene {
    /// An empty scene with a fixed camera at `(0, 1, 5)` looking at the origin, 30 fps, 1 frame.
    pub fn new(name: &str, description: &str) -> Scene {
        Scene {
            name: name.to_string(),
            description: description.to_string(),
            meshes: Vec::new(),
            instances: Vec::new(),
            camera: CameraPath::fixed(Vec3::new(0.0, 1.0, 5.0), Vec3::ZERO, 1.0),
            lights: Vec::new(),
            fps: 30.0,
            frame_count: 1,
            static_geometry: OnceLock::new(),
        }
    }

    /// Nothing moves: camera, instances and lights are static, so every frame is the same and
    /// the sequence may run any number of frames (convergence and still-frame savings).
    pub fn is_still(&self) -> bool {
        self.camera.is_static()
            && self.instances.iter().all(|i| i.motion.is_static())
            && self.lights.iter().all(|l| l.motion.is_static())
    }

    /// Frames a sequence may render: the animation's `frame_count`, or any number when the scene
    /// is still.
    pub fn frames_available(&self) -> u32 {
        if self.is_still() {
            u32::MAX
        } else {
            self.frame_count
        }
    }

    /// Adds a mesh and returns its index.
    pub fn add_mesh(&mut self, mesh: Mesh) -> usize {
        self.meshes.push(mesh);
        self.static_geometry = OnceLock::new();
        self.meshes.len() - 1
    }

    /// Adds an instance of mesh `mesh` and returns its id.
    pub fn add_instance(
        &mut self,
        name: &str,
        mesh: usize,
        motion: Trajectory,
        roughness: f32,
    ) -> u32 {
        assert!(
            mesh < self.meshes.len(),
            "instance of a mesh that does not exist"
        );
        self.instances.push(Instance {
            name: name.to_string(),
            mesh,
            motion,
            roughness,
        });
        self.static_geometry = OnceLock::new();
        (self.instances.len() - 1) as u32
    }

    /// Adds a mesh and one instance of it.
    pub fn add_object(
        &mut self,
        name: &str,
        mesh: Mesh,
        motion: Trajectory,
        roughness: f32,
    ) -> u32 {
        let m = self.add_mesh(mesh);
        self.add_instance(name, m, motion, roughness)
    }

    /// Adds an area light.
    pub fn add_light(&mut self, light: Light) {
        assert!(
            self.lights.len() < MAX_LIGHTS,
            "at most {MAX_LIGHTS} lights"
        );
        self.lights.push(light);
    }

    /// Checks that every frame has a defined image: finite camera keys looking somewhere (target
    /// away from the eye, field of view in (0, π)), finite instance motions and roughness, finite
    /// lights, a positive frame rate and at least one frame. A NaN camera would otherwise render
    /// as all sky, a silent blank. (A camera inside geometry is valid: it sees the inside.)
    pub fn validate(&self) -> Result<(), SceneError> {
        let invalid = |message: String| {
            Err(SceneError::InvalidScene {
                scene: self.name.clone(),
                message,
            })
        };
        if self.camera.keys.is_empty() {
            return invalid("the camera path has no keys".into());
        }
        for (i, k) in self.camera.keys.iter().enumerate() {
            let finite = k.time.is_finite() && k.position.is_finite() && k.target.is_finite();
            if !finite {
                return invalid(format!("camera key {i} is not finite: {k:?}"));
            }
            if !(k.fov_y > 0.0 && k.fov_y < std::f32::consts::PI) {
                return invalid(format!(
                    "camera key {i}: fov_y {} is outside (0, π)",
                    k.fov_y
                ));
            }
            if (k.target - k.position).length_squared() < 1e-12 {
                return invalid(format!("camera key {i} looks at its own position"));
            }
        }
        for inst in &self.instances {
            if inst.mesh >= self.meshes.len() {
                return invalid(format!("instance `{}`: no mesh {}", inst.name, inst.mesh));
            }
            if !(inst.motion.is_finite() && (0.0..=1.0).contains(&inst.roughness)) {
                return invalid(format!(
                    "instance `{}`: non-finite motion or roughness outside [0, 1]",
                    inst.name
                ));
            }
        }
        for (i, l) in self.lights.iter().enumerate() {
            let b = &l.base;
            let finite = b.corner().is_finite() && b.edge_u().is_finite() && b.edge_v().is_finite();
            if !finite || !l.motion.is_finite() {
                return invalid(format!("light {i} is not finite"));
            }
        }
        if !(self.fps.is_finite() && self.fps > 0.0) || self.frame_count == 0 {
            return invalid(format!(
                "{} fps, {} frames: needs a positive frame rate and a frame",
                self.fps, self.frame_count
            ));
        }
        Ok(())
    }

    /// True when no instance moves (the BVH is built once).
    pub fn geometry_is_static(&self) -> bool {
        self.instances.iter().all(|i| i.motion.is_static())
    }

    /// Total triangles over all instances.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh].triangle_count())
            .sum()
    }

    /// Time of frame `i` in seconds.
    pub fn time(&self, i: u32) -> f32 {
        i as f32 / self.fps
    }

    /// World-space triangles and BVH at time `t`.
    ///
    /// Vertices are transformed at each corner rather than into a world-space copy of each
    /// mesh (the same arithmetic, so the same bits), and the normals are made after the BVH, in
    /// its leaf order ([`bvh::build_owned_then_normals`]): the largest arrays alive at once are
    /// the meshes and the built geometry.
    pub fn geometry_at(&self, t: f32) -> Bvh {
        let placed: Vec<Affine3A> = self.instances.iter().map(|i| i.motion.at(t)).collect();
        let mut tris = Vec::with_capacity(self.triangle_count());
        for (id, (inst, m)) in self.instances.iter().zip(&placed).enumerate() {
            let mesh = &self.meshes[inst.mesh];
            tris.extend(mesh.indices.iter().map(|t| {
                let [a, b, c] = t.map(|i| m.transform_point3(mesh.positions[i as usize]));
                Triangle::new(a, b, c, id as u32)
            }));
        }
        // The first triangle of each instance, to find a triangle's instance by its index.
        let starts: Vec<usize> = self
            .instances
            .iter()
            .scan(0, |n, inst| {
                let start = *n;
                *n += self.meshes[inst.mesh].triangle_count();
                Some(start)
            })
            .collect();
        let normal_matrices: Vec<Mat3> = placed.iter().map(normal_matrix).collect();
        bvh::build_owned_then_normals(tris, |i| {
            let id = starts.partition_point(|&s| s <= i) - 1;
            let mesh = &self.meshes[self.instances[id].mesh];
            let nm = normal_matrices[id];
            let n = mesh.indices[i - starts[id]]
                .map(|v| (nm * mesh.normals[v as usize]).normalize_or(Vec3::Y));
            TriangleNormals::new(n[0], n[1], n[2])
        })
    }

    /// Everything the GPU needs for frame `i`.
    pub fn frame(&self, i: u32) -> FrameGeometry {
        let t = self.time(i);
        let prev_t = if i == 0 { t } else { self.time(i - 1) };
        let geometry = if self.geometry_is_static() {
            self.static_geometry
                .get_or_init(|| Arc::new(self.geometry_at(0.0)))
                .clone()
        } else {
            Arc::new(self.geometry_at(t))
        };
        let instances = self
            .instances
            .iter()
            .map(|inst| {
                let m = if inst.motion.is_static() || prev_t == t {
                    Affine3A::IDENTITY
                } else {
                    inst.motion.at(prev_t) * inst.motion.at(t).inverse()
                };
                instance_data(&m, inst.roughness)
            })
            .collect();
        FrameGeometry {
            index: i,
            time: t,
            geometry,
            instances,
            camera: self.camera.at(t),
            prev_camera: self.camera.at(prev_t),
            lights: self.lights.iter().map(|l| l.at(t)).collect(),
            camera_cut: i > 0 && self.camera.cut_between(prev_t, t),
        }
    }
}

/// The G-buffer's per-instance record from a current→previous map.
pub fn instance_data(m: &Affine3A, roughness: f32) -> InstanceData {
    let (x, y, z, t) = (
        m.matrix3.x_axis,
        m.matrix3.y_axis,
        m.matrix3.z_axis,
        m.translation,
    );
    InstanceData::from_rows(
        [x.x, y.x, z.x, t.x],
        [x.y, y.y, z.y, t.y],
        [x.z, y.z, z.z, t.z],
        roughness,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    #[test]
    fn instance_data_maps_points_like_the_affine() {
        let m = Affine3A::from_rotation_translation(
            vrrt_core::glam::Quat::from_rotation_y(0.3),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let d = instance_data(&m, 0.5);
        let p = Vec3::new(-0.5, 0.25, 4.0);
        assert!((d.previous_position(p) - m.transform_point3(p)).length() < 1e-6);
    }

    /// The geometry transformed at each corner, with normals made in leaf order, is the BVH
    /// built the plain way over world-space copies of the meshes' vertices: bit for bit, moving
    /// and mirrored instances included.
    #[test]
    fn geometry_equals_the_plain_build() {
        let mut room = crate::builtin::builtin("room").unwrap();
        room.add_object(
            "mirrored",
            shapes::uv_sphere(Vec3::ZERO, 0.5, 6, 9),
            Trajectory::Static(Affine3A::from_scale(Vec3::new(-1.0, 2.0, 1.0))),
            0.5,
        );
        for t in [0.0, 0.7, 1.3] {
            let mut tris = Vec::new();
            let mut normals = Vec::new();
            for (id, inst) in room.instances.iter().enumerate() {
                let mesh = &room.meshes[inst.mesh];
                let m = inst.motion.at(t);
                let nm = normal_matrix(&m);
                let p: Vec<Vec3> = mesh
                    .positions
                    .iter()
                    .map(|&p| m.transform_point3(p))
                    .collect();
                let n: Vec<Vec3> = mesh
                    .normals
                    .iter()
                    .map(|&v| (nm * v).normalize_or(Vec3::Y))
                    .collect();
                for tri in &mesh.indices {
                    let [a, b, c] = tri.map(|i| i as usize);
                    tris.push(Triangle::new(p[a], p[b], p[c], id as u32));
                    normals.push(TriangleNormals::new(n[a], n[b], n[c]));
                }
            }
            assert_eq!(room.geometry_at(t), bvh::build(&tris, &normals), "t = {t}");
        }
    }

    #[test]
    fn static_geometry_is_built_once() {
        let mut s = Scene::new("t", "test");
        s.add_object(
            "box",
            shapes::cuboid(Vec3::ZERO, Vec3::ONE),
            Trajectory::fixed(Vec3::X),
            1.0,
        );
        let a = s.frame(0);
        let b = s.frame(5);
        assert!(Arc::ptr_eq(&a.geometry, &b.geometry));
        assert_eq!(a.geometry.triangles.len(), 12);
        assert_eq!(b.instances[0], InstanceData::default());
    }
}
