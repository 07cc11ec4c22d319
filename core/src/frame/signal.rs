//! Which signals a frame denoises and where each lives among the denoiser's planes.

use crate::denoiser::Layout;
use crate::settings::{ReflectionSettings, Settings};
use core::fmt;

/// The ray-traced signal being denoised.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Signal {
    /// Ambient occlusion with a maximum distance (one plane).
    Ao {
        /// Occluders beyond this distance do not count.
        max_distance: f32,
    },
    /// Area-light shadows: one plane per light of the scene (up to 4).
    Shadows,
    /// Glossy reflections (`crate::reflections`, one plane), as `Settings::reflections` says.
    Reflections,
    /// AO, the shadows of every light and reflections in one frame: planes AO, shadows…,
    /// reflections, sharing reprojection and one ray budget.
    All {
        /// AO radius.
        max_distance: f32,
    },
}

/// Where each signal of a [`Signal`] lives among the denoiser's planes.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct PlaneLayout {
    /// The AO plane.
    pub ao: Option<u32>,
    /// First shadow plane and how many (one per light).
    pub shadows: Option<(u32, u32)>,
    /// The reflection plane.
    pub reflections: Option<u32>,
    /// Planes in all.
    pub planes: u32,
}

impl PlaneLayout {
    /// The shadow planes as a bit mask ([`Layout::shadow_planes`]).
    pub fn shadow_planes(&self) -> u32 {
        self.shadows
            .map_or(0, |(first, n)| ((1u32 << n) - 1) << first)
    }

    /// The AO plane as a bit mask ([`Layout::ao_planes`]).
    pub fn ao_planes(&self) -> u32 {
        self.ao.map_or(0, |z| 1 << z)
    }

    /// One plane group per signal, in plane order ([`Layout::plane_groups`]): AO, the shadows
    /// of every light, reflections.
    pub fn plane_groups(&self) -> u32 {
        let mut packed = 0;
        let mut group = 0;
        let mut z = 0;
        let mut put = |planes: u32| {
            for _ in 0..planes {
                packed |= group << (4 * z);
                z += 1;
            }
            group += 1;
        };
        if self.ao.is_some() {
            put(1);
        }
        if let Some((_, n)) = self.shadows {
            put(n);
        }
        if self.reflections.is_some() {
            put(1);
        }
        packed
    }
}

impl PlaneLayout {
    /// The denoiser's layout of these planes under `settings`: the shadow and AO planes marked,
    /// one plane group per signal with `rates.per_signal`, the reflection plane reprojected along
    /// the parallax with `reflections.parallax` and guided by its hit distance with
    /// `filter.guide_sigma`, and the first shadow plane guided by its penumbra with
    /// `filter.penumbra_reach`.
    pub fn denoiser(&self, settings: &Settings) -> Layout {
        Layout {
            planes: self.planes,
            parallax_plane: self.reflections.filter(|_| settings.reflections.parallax),
            guide_plane: self
                .reflections
                .filter(|_| settings.filter.guide_sigma > 0.0),
            penumbra_plane: self
                .shadows
                .map(|(first, _)| first)
                .filter(|_| settings.filter.penumbra_reach > 0.0),
            plane_groups: if settings.rates.per_signal {
                self.plane_groups()
            } else {
                0
            },
            shadow_planes: self.shadow_planes(),
            ao_planes: self.ao_planes(),
            reflections_alone: self.reflections.is_some() && self.planes == 1,
        }
    }
}

impl Signal {
    /// The planes of each signal for a frame with `lights` lights.
    pub fn layout(&self, lights: usize) -> PlaneLayout {
        let shadows = lights.clamp(1, 4) as u32;
        match self {
            Signal::Ao { .. } => PlaneLayout {
                ao: Some(0),
                planes: 1,
                ..PlaneLayout::default()
            },
            Signal::Shadows => PlaneLayout {
                shadows: Some((0, shadows)),
                planes: shadows,
                ..PlaneLayout::default()
            },
            Signal::Reflections => PlaneLayout {
                reflections: Some(0),
                planes: 1,
                ..PlaneLayout::default()
            },
            Signal::All { .. } => PlaneLayout {
                ao: Some(0),
                shadows: Some((1, shadows)),
                reflections: Some(1 + shadows),
                planes: 2 + shadows,
            },
        }
    }

    /// Signal planes for a frame with `lights` lights.
    pub fn planes(&self, lights: usize) -> u32 {
        self.layout(lights).planes
    }

    /// The AO radius, when the signal has AO.
    pub fn ao_distance(&self) -> Option<f32> {
        match *self {
            Signal::Ao { max_distance } | Signal::All { max_distance, .. } => Some(max_distance),
            _ => None,
        }
    }

    /// Whether the signal has reflections.
    pub fn has_reflections(&self) -> bool {
        matches!(self, Signal::Reflections | Signal::All { .. })
    }

    /// The signal's name with the reflection settings it is rendered with: what file names and
    /// cache keys use ([`SignalName`]).
    pub fn name(self, reflections: &ReflectionSettings) -> SignalName<'_> {
        SignalName {
            signal: self,
            reflections,
        }
    }

    /// Whether the signal is only shadows, which a frame without lights lacks entirely.
    pub fn needs_lights(&self) -> bool {
        *self == Signal::Shadows
    }
}

/// A signal's short name ([`Signal::name`]), used in file names and cache keys: it names
/// everything the estimator depends on (reflections: the roughness cut-off and the hit lighting
/// of `Settings::reflections`, not reuse or tiles).
#[derive(Copy, Clone, Debug)]
pub struct SignalName<'a> {
    signal: Signal,
    reflections: &'a ReflectionSettings,
}

impl SignalName<'_> {
    /// Whether the signal is reflections alone (whose references' cache key has its own
    /// version).
    pub fn is_reflections(&self) -> bool {
        self.signal == Signal::Reflections
    }
}

impl fmt::Display for SignalName<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self.reflections;
        let reflect = |f: &mut fmt::Formatter<'_>| {
            write!(
                f,
                "reflect{}-{}-{}-{}-{}",
                r.max_roughness, r.light_radiance, r.albedo, r.sky, r.ambient
            )
        };
        match self.signal {
            Signal::Ao { max_distance } => write!(f, "ao{max_distance}"),
            Signal::Shadows => f.write_str("shadows"),
            Signal::Reflections => reflect(f),
            Signal::All { max_distance } => {
                write!(f, "all-ao{max_distance}-")?;
                reflect(f)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_signal_is_its_own_plane_group() {
        let all = Signal::All { max_distance: 1.0 };
        assert_eq!(all.layout(2).plane_groups(), 0x2110);
        assert_eq!(all.layout(1).plane_groups(), 0x210);
        assert_eq!(Signal::Shadows.layout(3).plane_groups(), 0);
    }

    #[test]
    fn the_shadow_planes_are_marked_wherever_they_are() {
        let all = Signal::All { max_distance: 1.0 };
        assert_eq!(all.layout(2).shadow_planes(), 0b0110);
        assert_eq!(Signal::Shadows.layout(3).shadow_planes(), 0b111);
        assert_eq!(
            Signal::Ao { max_distance: 1.0 }.layout(3).shadow_planes(),
            0
        );
        assert_eq!(all.layout(2).ao_planes(), 0b0001);
        assert_eq!(Signal::Ao { max_distance: 1.0 }.layout(3).ao_planes(), 1);
        assert_eq!(Signal::Shadows.layout(3).ao_planes(), 0);
    }
}
