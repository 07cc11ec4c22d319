//! Where an event's crop is. An object's event is cropped to its screen-space footprint over the
//! window, taken from the scene (its bounds, motion and the camera), not from the moving mask:
//! on `room` the mask's bounding box is the whole frame in every frame before the cut (camera
//! motion flags edges everywhere, and the 256-spp references' own noise crosses the mask's
//! threshold), so it would not point at the object. Cuts and lights change the whole view, so
//! their crop is the whole frame. Either way the crop depends on the scene alone, so it is the
//! same for every configuration and budget.

use vrrt_core::glam::Vec3;
use vrrt_scene::{Event, EventKind, Scene};

/// Pixels added around the footprint on each side.
const PAD: u32 = 6;
/// Smallest crop side (or the image's, if smaller): a tiny footprint still shows its context.
const MIN_SIDE: u32 = 40;
/// Largest crop side: beyond it the crop is cut about the footprint's centre, so large benches
/// keep small images.
const MAX_SIDE: u32 = 320;
/// The side crops are upscaled towards (by a whole factor, nearest neighbour, at most 8).
const DISPLAY_SIDE: u32 = 200;

/// A rectangle of pixels, `x0..x1` × `y0..y1`.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Rect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Rect {
    /// The whole image.
    pub fn full((width, height): (u32, u32)) -> Rect {
        Rect {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    /// The whole factor that brings the longer side near [`DISPLAY_SIDE`] (1 to 8).
    pub fn display_scale(&self) -> u32 {
        (DISPLAY_SIDE / self.width().max(self.height()).max(1)).clamp(1, 8)
    }
}

/// The crop of `event` at `size` for the window's `frames` (in range, ascending); `None` when
/// its object is out of view in all of them.
pub fn crop(scene: &Scene, event: &Event, frames: &[u32], size: (u32, u32)) -> Option<Rect> {
    let region = match event.kind {
        EventKind::ObjectStarts { instance } => {
            // The frame before the event too: where the object was is what gets disoccluded.
            let before = event.frame.saturating_sub(1);
            let frames: Vec<u32> = std::iter::once(before)
                .chain(frames.iter().copied())
                .collect();
            footprint(scene, instance, &frames, size)?
        }
        EventKind::LightStarts { .. } | EventKind::CameraCut => Rect::full(size),
    };
    Some(fit(region, size))
}

/// Pixels covered by instance `instance`'s bounds over `frames`, each projected with its frame's
/// camera, grown by half the object's size in the world (its contact shadow and occlusion reach
/// past it). The whole image when the bounds straddle the eye's plane; frames that have them
/// wholly behind the eye add nothing.
fn footprint(scene: &Scene, instance: usize, frames: &[u32], size: (u32, u32)) -> Option<Rect> {
    let inst = scene.instances.get(instance)?;
    let (lo, hi) = scene.meshes.get(inst.mesh)?.bounds();
    let (w, h) = size;
    let (mut min, mut max) = ((f32::MAX, f32::MAX), (f32::MIN, f32::MIN));
    for &f in frames {
        let t = scene.time(f);
        let m = inst.motion.at(t);
        let world: Vec<Vec3> = corners(lo, hi).map(|c| m.transform_point3(c)).collect();
        let (wlo, whi) = world
            .iter()
            .fold((world[0], world[0]), |(a, b), &p| (a.min(p), b.max(p)));
        let margin = 0.5 * (whi - wlo).max_element();
        let camera = scene.camera.at(t);
        let grown: Vec<Vec3> = corners(wlo - margin, whi + margin).collect();
        let behind = grown.iter().filter(|&&c| camera.depth(c) <= 1e-3).count();
        if behind == grown.len() {
            continue;
        }
        if behind > 0 {
            return Some(Rect::full(size));
        }
        for c in grown {
            let (x, y) = camera.project_point(c, w, h);
            min = (min.0.min(x), min.1.min(y));
            max = (max.0.max(x), max.1.max(y));
        }
    }
    // Pixel centres sit at integer coordinates: pixel i covers [i − ½, i + ½).
    let clamp = |v: f32, len: u32| (v + 0.5).clamp(0.0, len as f32);
    let (x0, x1) = (clamp(min.0, w).floor(), clamp(max.0, w).ceil());
    let (y0, y1) = (clamp(min.1, h).floor(), clamp(max.1, h).ceil());
    (x0 < x1 && y0 < y1).then_some(Rect {
        x0: x0 as u32,
        y0: y0 as u32,
        x1: x1 as u32,
        y1: y1 as u32,
    })
}

fn corners(lo: Vec3, hi: Vec3) -> impl Iterator<Item = Vec3> {
    (0..8).map(move |i| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// `region` padded by [`PAD`], grown to [`MIN_SIDE`] and cut to [`MAX_SIDE`] about its centre,
/// inside the image.
pub fn fit(region: Rect, (width, height): (u32, u32)) -> Rect {
    let (x0, x1) = span(region.x0, region.x1, width);
    let (y0, y1) = span(region.y0, region.y1, height);
    Rect { x0, y0, x1, y1 }
}

fn span(lo: u32, hi: u32, len: u32) -> (u32, u32) {
    let lo = lo.saturating_sub(PAD).min(len);
    let hi = hi.saturating_add(PAD).clamp(lo, len);
    let side = (hi - lo).clamp(MIN_SIDE.min(len), MAX_SIDE.min(len));
    let centre = lo + (hi - lo) / 2;
    let start = centre.saturating_sub(side / 2).min(len - side);
    (start, start + side)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vrrt_scene::builtin::{builtin, room_ids};

    fn rect(x0: u32, y0: u32, x1: u32, y1: u32) -> Rect {
        Rect { x0, y0, x1, y1 }
    }

    #[test]
    fn fit_pads_grows_caps_and_stays_inside() {
        // Padded by 6 on each side.
        assert_eq!(
            fit(rect(50, 40, 100, 90), (400, 300)),
            rect(44, 34, 106, 96)
        );
        // A 2x2 footprint grows to 40x40 about its centre.
        assert_eq!(
            fit(rect(100, 100, 102, 102), (400, 300)),
            rect(81, 81, 121, 121)
        );
        // At the border the minimum side shifts inwards.
        assert_eq!(fit(rect(0, 0, 1, 1), (400, 300)), rect(0, 0, 40, 40));
        assert_eq!(
            fit(rect(399, 299, 400, 300), (400, 300)),
            rect(360, 260, 400, 300)
        );
        // Larger than the cap: 320 about the centre.
        let r = fit(Rect::full((1280, 720)), (1280, 720));
        assert_eq!(r, rect(480, 200, 800, 520));
        // Images smaller than the minimum are shown whole.
        assert_eq!(fit(rect(3, 2, 4, 3), (24, 16)), Rect::full((24, 16)));
        assert_eq!(rect(0, 0, 40, 20).display_scale(), 5);
        assert_eq!(rect(0, 0, 320, 180).display_scale(), 1);
        assert_eq!(rect(0, 0, 8, 8).display_scale(), 8);
    }

    #[test]
    fn room_crops_follow_the_objects() {
        let room = builtin("room").unwrap();
        let events = room.events();
        let size = (160, 90);
        let window = |e: &Event| -> Vec<u32> { [0, 1, 2, 4, 8, 16].map(|o| e.frame + o).into() };
        let of = |instance: u32| {
            events
                .iter()
                .find(|e| {
                    e.kind
                        == EventKind::ObjectStarts {
                            instance: instance as usize,
                        }
                })
                .unwrap()
        };
        // The box slides along the back wall, near the middle of the view.
        let b = of(room_ids::SLIDING_BOX);
        let r = crop(&room, b, &window(b), size).unwrap();
        assert!(r.width() < 120 && r.height() < 60, "{r:?}");
        assert!(r.x0 < 80 && r.x1 > 80, "{r:?}");
        // The sphere enters from the left, low in the view.
        let s = of(room_ids::CROSSING_SPHERE);
        let r = crop(&room, s, &window(s), size).unwrap();
        assert_eq!(r.x0, 0, "{r:?}");
        assert!(r.x1 < 110 && r.y1 > 60, "{r:?}");
        // The cut shows the whole frame.
        let cut = events
            .iter()
            .find(|e| e.kind == EventKind::CameraCut)
            .unwrap();
        assert_eq!(crop(&room, cut, &window(cut), size), Some(Rect::full(size)));
    }

    #[test]
    fn an_object_behind_the_eye_has_no_crop_and_one_around_it_fills_the_view() {
        let mut room = builtin("room").unwrap();
        let sphere = room_ids::CROSSING_SPHERE as usize;
        // The camera at z = 7.5 looks towards −z: a sphere at z = 40 is wholly behind it.
        room.instances[sphere].motion = vrrt_scene::animation::Trajectory::Linear {
            base: vrrt_core::glam::Affine3A::from_translation(Vec3::new(0.0, 1.0, 40.0)),
            velocity: Vec3::X,
        };
        let e = Event {
            frame: 10,
            kind: EventKind::ObjectStarts { instance: sphere },
            label: String::new(),
        };
        assert_eq!(crop(&room, &e, &[10, 11], (160, 90)), None);
        // Around the eye (z = 7.5) its bounds straddle the eye's plane: the whole view.
        room.instances[sphere].motion = vrrt_scene::animation::Trajectory::Linear {
            base: vrrt_core::glam::Affine3A::from_translation(Vec3::new(0.0, 2.2, 7.5)),
            velocity: Vec3::X,
        };
        assert_eq!(
            crop(&room, &e, &[10, 11], (160, 90)),
            Some(Rect::full((160, 90)))
        );
    }
}
