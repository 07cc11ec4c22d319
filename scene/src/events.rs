//! The moments of an animation that temporal denoisers get wrong — an object or a light starts
//! moving, the camera cuts — found from the scene description itself, so that any scene (built
//! in or loaded) names the frames worth looking at closely.

use crate::scene::Scene;
use vrrt_core::glam::Affine3A;

/// What happens at an [`Event`].
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum EventKind {
    /// Instance `instance` (an index into [`Scene::instances`]) starts moving: stale history
    /// lags behind it and its old place is disoccluded.
    ObjectStarts {
        /// The instance.
        instance: usize,
    },
    /// Light `light` (an index into [`Scene::lights`]) starts moving: shadows and reflections
    /// change where no geometry moves, which reprojection cannot see.
    LightStarts {
        /// The light.
        light: usize,
    },
    /// The camera cuts: every pixel loses its history at once.
    CameraCut,
}

/// A frame at which something starts that breaks temporal history.
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    /// The first frame that shows it: the frame whose motion vectors (or cut flag) carry it.
    pub frame: u32,
    /// What happens.
    pub kind: EventKind,
    /// What happens, in words naming the object or light ("sliding box starts moving").
    pub label: String,
}

impl Scene {
    /// Every event of the animation's `frame_count` frames, sorted by frame (cuts first within
    /// a frame, then objects and lights in scene order).
    ///
    /// A thing "starts moving" at frame `f` when its transform at `f` differs from that at
    /// `f − 1` (by more than rounding) but the one at `f − 1` did not differ from `f − 2`. Frame 0 has no previous frame
    /// (the renderer treats it as its own), so something moving from the start starts at frame
    /// 1. A cut at `f` is one in `(t(f − 1), t(f)]`, as [`Scene::frame`] flags it.
    pub fn events(&self) -> Vec<Event> {
        let mut events = Vec::new();
        for f in 1..self.frame_count {
            if self.camera.cut_between(self.time(f - 1), self.time(f)) {
                events.push(Event {
                    frame: f,
                    kind: EventKind::CameraCut,
                    label: "camera cut".to_string(),
                });
            }
        }
        for (instance, inst) in self.instances.iter().enumerate() {
            if inst.motion.is_static() {
                continue;
            }
            for frame in self.starts(|t| inst.motion.at(t)) {
                events.push(Event {
                    frame,
                    kind: EventKind::ObjectStarts { instance },
                    label: format!("{} starts moving", inst.name),
                });
            }
        }
        for (light, l) in self.lights.iter().enumerate() {
            if l.motion.is_static() {
                continue;
            }
            for frame in self.starts(|t| l.motion.at(t)) {
                events.push(Event {
                    frame,
                    kind: EventKind::LightStarts { light },
                    label: format!("light {light} starts moving"),
                });
            }
        }
        // Stable: within a frame cuts stay before objects, objects before lights.
        events.sort_by_key(|e| e.frame);
        events
    }

    /// Frames at which a transform over time starts changing (see [`Scene::events`]).
    fn starts(&self, at: impl Fn(f32) -> Affine3A) -> Vec<u32> {
        let mut starts = Vec::new();
        let mut before = at(self.time(0));
        let mut was_moving = false;
        for f in 1..self.frame_count {
            let now = at(self.time(f));
            let moving = differs(&now, &before);
            if moving && !was_moving {
                starts.push(f);
            }
            (before, was_moving) = (now, moving);
        }
        starts
    }
}

/// Two transforms differ by more than rounding: keyframe interpolation between equal keys may
/// move the last bits (slerp renormalises), which is no motion anyone could see.
fn differs(a: &Affine3A, b: &Affine3A) -> bool {
    let scale = 1.0
        + a.translation
            .abs()
            .max_element()
            .max(b.translation.abs().max_element());
    !a.abs_diff_eq(*b, 1e-6 * scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::animation::{RigidKey, Trajectory};
    use crate::builtin::{builtin, room_ids, ROOM_CUT_FRAME};
    use crate::shapes;
    use vrrt_core::glam::{Quat, Vec3};

    #[test]
    fn room_events_are_its_animation() {
        let room = builtin("room").unwrap();
        let events = room.events();
        let summary: Vec<(u32, EventKind)> = events.iter().map(|e| (e.frame, e.kind)).collect();
        // The box slides and the light sweeps from the start (sines, moving at t = 0); the
        // sphere waits at its first key (0.3 s = frame 9) and moves from frame 10; the camera
        // cuts at 60. The sphere later turns (frames 57, 72) and stops (114): no new starts.
        assert_eq!(
            summary,
            [
                (
                    1,
                    EventKind::ObjectStarts {
                        instance: room_ids::SLIDING_BOX as usize
                    }
                ),
                (1, EventKind::LightStarts { light: 0 }),
                (
                    10,
                    EventKind::ObjectStarts {
                        instance: room_ids::CROSSING_SPHERE as usize
                    }
                ),
                (ROOM_CUT_FRAME, EventKind::CameraCut),
            ]
        );
        assert_eq!(events[0].label, "sliding box starts moving");
        assert_eq!(events[1].label, "light 0 starts moving");
        assert_eq!(events[2].label, "crossing sphere starts moving");
        assert_eq!(events[3].label, "camera cut");
        // The definition, checked against the frames the renderer evaluates.
        let sphere = &room.instances[room_ids::CROSSING_SPHERE as usize].motion;
        let at = |f: u32| sphere.at(room.time(f));
        assert!(at(8) == at(9) && at(9) != at(10));
        assert!(room.frame(ROOM_CUT_FRAME).camera_cut);
    }

    #[test]
    fn a_still_scene_has_no_events() {
        assert!(builtin("room_static").unwrap().events().is_empty());
    }

    #[test]
    fn an_object_that_stops_and_starts_again_starts_twice() {
        let key = |time: f32, x: f32| RigidKey {
            time,
            translation: Vec3::X * x,
            rotation: Quat::IDENTITY,
        };
        let mut s = Scene::new("t", "test");
        s.frame_count = 30;
        s.fps = 10.0;
        // Held until 0.5 s, moves to 1.0 s, held, moves again from 2.0 s to 2.5 s.
        let motion = Trajectory::Keyframes(vec![
            key(0.5, 0.0),
            key(1.0, 1.0),
            key(2.0, 1.0),
            key(2.5, 3.0),
        ]);
        s.add_object("<cube>", shapes::cuboid(Vec3::ZERO, Vec3::ONE), motion, 1.0);
        let events = s.events();
        let frames: Vec<u32> = events.iter().map(|e| e.frame).collect();
        assert_eq!(frames, [6, 21]);
        assert_eq!(events[0].label, "<cube> starts moving");
    }
}
