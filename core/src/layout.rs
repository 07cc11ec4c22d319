//! The denoiser's planes and what each one is: decided by the frame from its signal, not tuned.
//! Below the denoiser and its buffers, which both size themselves by it.

use crate::kernels::{self, balance::MAX_GROUPS, MAX_GROUPED_PLANES};
use crate::settings::{check, SettingsError};

/// Where the denoiser's planes are and which rules each takes, fixed for a denoiser's life.
///
/// It is apart from [`Settings`](crate::settings::Settings), as NRD keeps `CommonSettings` (what
/// this frame is) apart from `ReblurSettings` (how to denoise it): the settings are the user's
/// tunables, this follows from the signal. `crate::frame::Frame` derives it from the signal's
/// planes ([`PlaneLayout::denoiser`](crate::frame::PlaneLayout::denoiser)); a caller that drives
/// [`Denoiser`](crate::denoiser::Denoiser) itself states it
/// ([`Denoiser::with_layout`](crate::denoiser::Denoiser::with_layout)).
/// `Default` is one plane with no special rule.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Scalar signal planes denoised together (1..=4: AO, shadows of up to 4 lights).
    pub planes: u32,
    /// Plane reprojected along the reflection parallax (`kernels::reflect::reflect_motion`, which
    /// the caller runs into `Denoiser::parallax` before `Denoiser::plan_rays`) instead of the
    /// surface motion (0..planes); `None` for none.
    pub parallax_plane: Option<u32>,
    /// Plane whose à-trous taps also compare the hit-distance guide (`Denoiser::guide`, which
    /// the caller writes before `Denoiser::resolve`: `kernels::reflect::reflect_guide`) at
    /// `filter.guide_sigma` (0..planes); `None` for none. The frame's reflection plane when
    /// `guide_sigma > 0`.
    pub guide_plane: Option<u32>,
    /// Shadow plane whose à-trous taps stay within its penumbra (`kernels::penumbra`, from
    /// raygen's `Denoiser::blockers`; 0..planes); `None` for none. The frame's first shadow plane
    /// when `filter.penumbra_reach > 0`.
    pub penumbra_plane: Option<u32>,
    /// Which group each plane belongs to, 4 bits per plane from plane 0 up
    /// (`kernels::plane_group`; groups number 0, 1, … in plane order). Each group (a signal: AO,
    /// the shadows of every light, reflections) has its own ray requests, decision and work list
    /// under one shared budget (`rates.signal_floor`). 0: one group, every plane traced together
    /// (the frame's choice without `rates.per_signal`).
    pub plane_groups: u32,
    /// Planes that take the shadows' detector window (`detector.shadow_radius`,
    /// `detector.shadow_threshold`), one bit per plane from plane 0 up; the others take
    /// `detector.radius` and `detector.threshold`. 0: none. A shared frame marks its shadow
    /// planes too.
    pub shadow_planes: u32,
    /// The AO planes (bit per plane), whose detector counts a change from `detector.ao_sigma`
    /// instead of `detector.sigma` and whose filter takes the AO variants. 0: none.
    pub ao_planes: u32,
    /// The one plane is reflections: a reset's boost is paid back over
    /// `reflections.reset_payback` frames instead of `rates.reset_payback`.
    pub reflections_alone: bool,
}

impl Default for Layout {
    fn default() -> Self {
        Layout::with_planes(1)
    }
}

impl Layout {
    /// `planes` planes in one group, none with a rule of its own.
    pub fn with_planes(planes: u32) -> Self {
        Layout {
            planes,
            parallax_plane: None,
            guide_plane: None,
            penumbra_plane: None,
            plane_groups: 0,
            shadow_planes: 0,
            ao_planes: 0,
            reflections_alone: false,
        }
    }

    /// Every plane is a shadow ([`Self::shadow_planes`] holds them all): reset frames spend
    /// `rates.shadow_reset_boost` ahead and `rates.reset_refill` of it on the penumbrae (a
    /// reserve of the whole frame's boost, which in a shared frame the other signals would pay
    /// for), and the balancer shifts their requests.
    pub fn shadows_alone(&self) -> bool {
        self.shadow_planes == all_planes(self.planes)
    }

    /// Every plane is AO ([`Self::ao_planes`] holds them all): a reset spends
    /// `rates.ao_reset_boost` ahead instead of `rates.reset_boost`, and `rates.ao_reset_refill`
    /// of it on the pixels of contrasted windows.
    pub fn ao_alone(&self) -> bool {
        self.ao_planes == all_planes(self.planes)
    }

    /// Plane groups ([`Self::plane_groups`]): each has its own requests and work list.
    pub fn groups(&self) -> u32 {
        kernels::plane_group(self.plane_groups, self.planes.max(1) - 1) + 1
    }

    /// Checks every field against its documented range; errors name the field as
    /// `layout.<field>`.
    pub fn validate(&self) -> Result<(), SettingsError> {
        check(
            (1..=4).contains(&self.planes),
            "layout.planes",
            self.planes,
            "1..=4",
        )?;
        check(
            groups_in_order(self.plane_groups, self.planes),
            "layout.plane_groups",
            self.plane_groups,
            "4 bits per plane: groups 0, 1, … in plane order, at most 4, none past the planes",
        )?;
        check(
            self.shadow_planes >> self.planes == 0,
            "layout.shadow_planes",
            self.shadow_planes,
            "one bit per plane, none past the planes",
        )?;
        check(
            self.ao_planes >> self.planes == 0 && self.ao_planes & self.shadow_planes == 0,
            "layout.ao_planes",
            self.ao_planes,
            "one bit per plane, none past the planes or among the shadow planes",
        )?;
        for (plane, field) in [
            (self.parallax_plane, "layout.parallax_plane"),
            (self.guide_plane, "layout.guide_plane"),
            (self.penumbra_plane, "layout.penumbra_plane"),
        ] {
            if let Some(z) = plane {
                check(z < self.planes, field, z, "a plane (< planes)")?;
            }
        }
        Ok(())
    }
}

/// One bit for each of `planes` planes, from plane 0 up.
fn all_planes(planes: u32) -> u32 {
    if planes >= 32 {
        u32::MAX
    } else {
        (1u32 << planes) - 1
    }
}

/// Whether `groups` numbers the `planes` planes 0, 1, … in order (each plane in its
/// predecessor's group or the next), with at most `balance::MAX_GROUPS` groups and no bits past
/// the last plane.
fn groups_in_order(groups: u32, planes: u32) -> bool {
    if planes == 0 || planes > MAX_GROUPED_PLANES {
        return groups == 0;
    }
    let mut prev = 0;
    for z in 0..planes {
        let g = kernels::plane_group(groups, z);
        if g != prev && !(z > 0 && g == prev + 1) {
            return false;
        }
        prev = g;
    }
    let unused = if planes == MAX_GROUPED_PLANES {
        0
    } else {
        groups >> (4 * planes)
    };
    prev < MAX_GROUPS && unused == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field_of(l: &Layout) -> &'static str {
        match l.validate() {
            Err(SettingsError::OutOfRange { field, .. }) => field,
            other => panic!("expected an out-of-range error, got {other:?}"),
        }
    }

    #[test]
    fn out_of_range_fields_are_named() {
        let d = Layout::default();
        assert_eq!(d.validate(), Ok(()));
        assert_eq!(field_of(&Layout::with_planes(5)), "layout.planes");
        let parallax = Layout {
            parallax_plane: Some(1),
            ..d
        };
        assert_eq!(field_of(&parallax), "layout.parallax_plane");
        let ao = Layout {
            planes: 2,
            shadow_planes: 0b10,
            ao_planes: 0b11,
            ..d
        };
        assert_eq!(field_of(&ao), "layout.ao_planes");
    }

    #[test]
    fn ao_alone_is_every_plane_ao() {
        let ao = Layout {
            ao_planes: 1,
            ..Layout::with_planes(1)
        };
        assert!(ao.ao_alone());
        let shared = Layout {
            planes: 3,
            shadow_planes: 0b010,
            ..ao
        };
        assert!(!shared.ao_alone(), "a shared frame's AO plane is not alone");
        assert!(!Layout::with_planes(1).ao_alone());
    }

    #[test]
    fn plane_groups_number_the_planes_in_order() {
        let with = |planes, plane_groups| Layout {
            plane_groups,
            ..Layout::with_planes(planes)
        };
        // AO, two shadow planes, reflections: groups 0, 1, 1, 2.
        let all = with(4, 0x2110);
        assert_eq!(all.validate(), Ok(()));
        assert_eq!(all.groups(), 3);
        assert_eq!(with(3, 0).groups(), 1);
        for bad in [
            with(2, 0x01),  // starts at group 1
            with(3, 0x200), // skips group 1
            with(3, 0x101), // goes back
            with(2, 0x110), // a group past the last plane
        ] {
            assert_eq!(
                field_of(&bad),
                "layout.plane_groups",
                "{:x}",
                bad.plane_groups
            );
        }
    }
}
