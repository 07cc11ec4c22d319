//! The `--signal` values and how a signal's planes split into parts, each measured against its
//! own reference.

use vrrt_scene::render::Signal;

/// The `--signal` argument: a name the command line parses, mapped onto core's [`Signal`] with
/// its parameters ([`Self::signal`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SignalArg {
    /// Ambient occlusion (one plane), up to `--ao-radius`.
    Ao,
    /// Area-light shadows (one plane per light).
    Shadows,
    /// Glossy reflections (one plane of HDR radiance; the settings' `[reflections]`).
    Reflections,
    /// AO, shadows and reflections in one frame, sharing one ray budget.
    All,
}

impl SignalArg {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SignalArg::Ao => "ao",
            SignalArg::Shadows => "shadows",
            SignalArg::Reflections => "reflections",
            SignalArg::All => "all",
        }
    }

    /// The renderer's signal, with the AO distance `ao_radius`.
    pub fn signal(self, ao_radius: f32) -> Signal {
        match self {
            SignalArg::Ao => Signal::Ao {
                max_distance: ao_radius,
            },
            SignalArg::Shadows => Signal::Shadows,
            SignalArg::Reflections => Signal::Reflections,
            SignalArg::All => Signal::All {
                max_distance: ao_radius,
            },
        }
    }
}

/// One signal among a frame's planes (`Signal::All` has three). Each part is measured against
/// its own reference, cached under the part's signal alone, so `all` reuses the references of
/// `ao`, `shadows` and `reflections`; and its images keep 1, 3 or 4 channels, which PNG, EXR
/// and the cache need.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Part {
    /// `ao`, `shadows` or `reflections`: the suffix of its files and columns.
    pub name: &'static str,
    /// The signal on its own.
    pub signal: Signal,
    /// First plane and how many.
    pub planes: (u32, u32),
}

/// The parts of `signal` in plane order, for a scene with `lights` lights.
pub fn parts(signal: Signal, lights: usize) -> Vec<Part> {
    let layout = signal.layout(lights);
    let mut parts = Vec::new();
    if let (Some(plane), Signal::Ao { max_distance } | Signal::All { max_distance, .. }) =
        (layout.ao, signal)
    {
        parts.push(Part {
            name: "ao",
            signal: Signal::Ao { max_distance },
            planes: (plane, 1),
        });
    }
    if let Some(planes) = layout.shadows {
        parts.push(Part {
            name: "shadows",
            signal: Signal::Shadows,
            planes,
        });
    }
    if let Some(plane) = layout.reflections {
        parts.push(Part {
            name: "reflections",
            signal: Signal::Reflections,
            planes: (plane, 1),
        });
    }
    parts
}

/// The names of `signal`'s planes in order, for a scene with `lights` lights: `ao`,
/// `shadow0`, `shadow1`, …, `reflections` (what summaries call them; the files and columns
/// are named by [`Part`]).
pub fn plane_names(signal: Signal, lights: usize) -> Vec<String> {
    let layout = signal.layout(lights);
    let mut names = Vec::new();
    if layout.ao.is_some() {
        names.push("ao".to_string());
    }
    if let Some((_, n)) = layout.shadows {
        names.extend((0..n).map(|i| format!("shadow{i}")));
    }
    if layout.reflections.is_some() {
        names.push("reflections".to_string());
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_are_named_by_what_they_hold() {
        let all = SignalArg::All.signal(1.0);
        assert_eq!(
            plane_names(all, 2),
            ["ao", "shadow0", "shadow1", "reflections"]
        );
        assert_eq!(plane_names(SignalArg::Ao.signal(1.0), 2), ["ao"]);
        assert_eq!(plane_names(Signal::Shadows, 0), ["shadow0"]);
    }
}
