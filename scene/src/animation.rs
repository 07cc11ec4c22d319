//! Animation as pure functions of time: rigid instance motions, camera paths with cuts, and
//! moving area lights. A frame is evaluated at `t` and `t − 1/fps`; motion vectors come from the
//! difference, so every animation must be a deterministic function of `t`.

use vrrt_core::camera::Camera;
use vrrt_core::glam::{Affine3A, Mat3, Quat, Vec3};
use vrrt_core::kernels::raygen::AreaLight;
use vrrt_core::math;

/// One key of a rigid keyframe animation.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RigidKey {
    /// Time in seconds.
    pub time: f32,
    /// Translation at that time.
    pub translation: Vec3,
    /// Rotation at that time.
    pub rotation: Quat,
}

/// A transform as a function of time: how an instance or a light moves (named apart from
/// core's `Motion`, the per-pixel motion vectors the renderer derives from it).
#[derive(Clone, Debug, PartialEq)]
pub enum Trajectory {
    /// Never moves.
    Static(Affine3A),
    /// `base`, then translated by `velocity · t`.
    Linear {
        /// Transform at `t = 0`.
        base: Affine3A,
        /// World-space velocity (units per second).
        velocity: Vec3,
    },
    /// `base`, then translated by `amplitude · sin(2π (t / period + phase))`.
    Oscillate {
        /// Transform at the centre of the swing.
        base: Affine3A,
        /// Peak world-space offset.
        amplitude: Vec3,
        /// Seconds per cycle.
        period: f32,
        /// Phase in cycles.
        phase: f32,
    },
    /// `base`, then rotated about the world-space vertical line through its origin at
    /// `turns_per_second`.
    Spin {
        /// Transform at `t = 0`.
        base: Affine3A,
        /// Turns per second around +Y.
        turns_per_second: f32,
    },
    /// Linear interpolation of translation and slerp of rotation between keys (sorted by time),
    /// held constant before the first and after the last key.
    Keyframes(Vec<RigidKey>),
}

impl Trajectory {
    /// Every parameter is finite, so every `at(t)` is (given a finite `t`).
    pub fn is_finite(&self) -> bool {
        match self {
            Trajectory::Static(base) => base.is_finite(),
            Trajectory::Linear { base, velocity } => base.is_finite() && velocity.is_finite(),
            Trajectory::Oscillate {
                base,
                amplitude,
                period,
                phase,
            } => {
                base.is_finite()
                    && amplitude.is_finite()
                    && period.is_finite()
                    && *period != 0.0
                    && phase.is_finite()
            }
            Trajectory::Spin {
                base,
                turns_per_second,
            } => base.is_finite() && turns_per_second.is_finite(),
            Trajectory::Keyframes(keys) => keys
                .iter()
                .all(|k| k.time.is_finite() && k.translation.is_finite() && k.rotation.is_finite()),
        }
    }

    /// A motion that never moves, at translation `t`.
    pub fn fixed(t: Vec3) -> Trajectory {
        Trajectory::Static(Affine3A::from_translation(t))
    }

    /// True when the transform does not depend on time.
    pub fn is_static(&self) -> bool {
        match self {
            Trajectory::Static(_) => true,
            Trajectory::Keyframes(keys) => keys.len() <= 1,
            _ => false,
        }
    }

    /// The transform at time `t` (seconds).
    pub fn at(&self, t: f32) -> Affine3A {
        match self {
            Trajectory::Static(m) => *m,
            Trajectory::Linear { base, velocity } => {
                Affine3A::from_translation(*velocity * t) * *base
            }
            Trajectory::Oscillate {
                base,
                amplitude,
                period,
                phase,
            } => {
                let (s, _) = math::sin_cos_turns(t / *period + *phase);
                Affine3A::from_translation(*amplitude * s) * *base
            }
            Trajectory::Spin {
                base,
                turns_per_second,
            } => {
                let (s, c) = math::sin_cos_turns(t * *turns_per_second);
                let rotation =
                    Mat3::from_cols(Vec3::new(c, 0.0, -s), Vec3::Y, Vec3::new(s, 0.0, c));
                let origin = Vec3::from(base.translation);
                Affine3A::from_translation(origin)
                    * Affine3A::from_mat3(rotation)
                    * Affine3A::from_translation(-origin)
                    * *base
            }
            Trajectory::Keyframes(keys) => match keys.as_slice() {
                [] => Affine3A::IDENTITY,
                [k] => Affine3A::from_rotation_translation(k.rotation, k.translation),
                _ => {
                    let i = keys.partition_point(|k| k.time <= t);
                    if i == 0 {
                        let k = keys[0];
                        return Affine3A::from_rotation_translation(k.rotation, k.translation);
                    }
                    if i == keys.len() {
                        let k = keys[i - 1];
                        return Affine3A::from_rotation_translation(k.rotation, k.translation);
                    }
                    let (a, b) = (keys[i - 1], keys[i]);
                    let s = ((t - a.time) / (b.time - a.time)).clamp(0.0, 1.0);
                    Affine3A::from_rotation_translation(
                        a.rotation.slerp(b.rotation, s),
                        a.translation.lerp(b.translation, s),
                    )
                }
            },
        }
    }
}

/// One camera key.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CameraKey {
    /// Time in seconds.
    pub time: f32,
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// A camera cut: the path jumps to this key at its time instead of moving there.
    pub cut: bool,
}

/// A camera path: keys sorted by time, linearly interpolated (position, target, fov) except
/// across cuts; held before the first and after the last key. World up is +Y.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    /// The keys.
    pub keys: Vec<CameraKey>,
}

impl CameraPath {
    /// A camera that never moves.
    pub fn fixed(position: Vec3, target: Vec3, fov_y: f32) -> CameraPath {
        CameraPath {
            keys: vec![CameraKey {
                time: 0.0,
                position,
                target,
                fov_y,
                cut: false,
            }],
        }
    }

    /// True when the camera does not move.
    pub fn is_static(&self) -> bool {
        self.keys.windows(2).all(|w| {
            w[0].position == w[1].position && w[0].target == w[1].target && w[0].fov_y == w[1].fov_y
        })
    }

    /// The interpolated key at time `t`.
    pub fn key_at(&self, t: f32) -> CameraKey {
        let keys = &self.keys;
        assert!(!keys.is_empty(), "camera path without keys");
        let i = keys.partition_point(|k| k.time <= t);
        if i == 0 {
            return keys[0];
        }
        if i == keys.len() || keys[i].cut {
            return keys[i - 1];
        }
        let (a, b) = (keys[i - 1], keys[i]);
        let s = ((t - a.time) / (b.time - a.time)).clamp(0.0, 1.0);
        CameraKey {
            time: t,
            position: a.position.lerp(b.position, s),
            target: a.target.lerp(b.target, s),
            fov_y: a.fov_y + (b.fov_y - a.fov_y) * s,
            cut: false,
        }
    }

    /// The camera at time `t`.
    pub fn at(&self, t: f32) -> Camera {
        let k = self.key_at(t);
        Camera::look_at(k.position, k.target, Vec3::Y, k.fov_y)
    }

    /// True when a cut happens in `(t0, t1]`.
    pub fn cut_between(&self, t0: f32, t1: f32) -> bool {
        self.keys
            .iter()
            .any(|k| k.cut && k.time > t0 && k.time <= t1)
    }
}

/// A rectangular area light moved rigidly by a [`Trajectory`].
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// The light at the identity transform.
    pub base: AreaLight,
    /// Its motion.
    pub motion: Trajectory,
}

impl Light {
    /// The light at time `t`.
    pub fn at(&self, t: f32) -> AreaLight {
        let m = self.motion.at(t);
        AreaLight::new(
            m.transform_point3(self.base.corner()),
            m.transform_vector3(self.base.edge_u()),
            m.transform_vector3(self.base.edge_v()),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keyframes_interpolate_and_hold() {
        let m = Trajectory::Keyframes(vec![
            RigidKey {
                time: 1.0,
                translation: Vec3::ZERO,
                rotation: Quat::IDENTITY,
            },
            RigidKey {
                time: 3.0,
                translation: Vec3::X * 4.0,
                rotation: Quat::IDENTITY,
            },
        ]);
        assert_eq!(m.at(0.0).translation, Vec3::ZERO.into());
        assert_eq!(m.at(2.0).translation, (Vec3::X * 2.0).into());
        assert_eq!(m.at(9.0).translation, (Vec3::X * 4.0).into());
        let osc = Trajectory::Oscillate {
            base: Affine3A::IDENTITY,
            amplitude: Vec3::X,
            period: 4.0,
            phase: 0.0,
        };
        assert!((osc.at(1.0).translation.x - 1.0).abs() < 1e-6);
    }

    #[test]
    fn camera_cut_jumps() {
        let key = |time, x: f32, cut| CameraKey {
            time,
            position: Vec3::new(x, 1.0, 5.0),
            target: Vec3::ZERO,
            fov_y: 1.0,
            cut,
        };
        let path = CameraPath {
            keys: vec![
                key(0.0, 0.0, false),
                key(1.0, 1.0, false),
                key(2.0, 9.0, true),
            ],
        };
        assert_eq!(path.key_at(0.5).position.x, 0.5);
        assert_eq!(path.key_at(1.5).position.x, 1.0, "held until the cut");
        assert_eq!(path.key_at(2.0).position.x, 9.0);
        assert!(path.cut_between(1.9, 2.0) && !path.cut_between(2.0, 2.1));
        let spin = Trajectory::Spin {
            base: Affine3A::from_translation(Vec3::X),
            turns_per_second: 0.25,
        };
        let p = spin.at(1.0).transform_point3(Vec3::X);
        assert!((p - Vec3::new(1.0, 0.0, -1.0)).length() < 1e-5, "{p}");
    }
}
