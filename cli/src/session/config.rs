//! The denoiser configurations compared by `run` and `bench` (the baselines and the stages of
//! VRRT) and the denoiser settings each one stands for.

use vrrt_core::denoiser::Settings;
use vrrt_scene::render::Signal;

/// A denoiser configuration: the baselines and the stages of VRRT.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Config {
    /// No denoising: this frame's raw samples at a fixed rate.
    Raw,
    /// SVGF at a fixed rate.
    Svgf,
    /// SVGF with a variance clamp of history.
    SvgfClamp,
    /// VRRT supersampling only (no load balancing, no undersampling).
    VrrtSuper,
    /// VRRT supersampling with load balancing (no undersampling).
    VrrtBalance,
    /// Full VRRT: supersampling, load balancing and undersampling.
    Vrrt,
    /// Full VRRT in "save" mode: rays the plan saves stay unspent.
    VrrtSave,
    /// Full VRRT with nothing skipped: every tile runs every filter iteration and still pixels
    /// keep their rays (what the adaptive plan is measured against).
    VrrtNoskip,
}

impl Config {
    /// Every configuration, baselines first.
    pub const ALL: [Config; 8] = [
        Config::Raw,
        Config::Svgf,
        Config::SvgfClamp,
        Config::VrrtSuper,
        Config::VrrtBalance,
        Config::Vrrt,
        Config::VrrtSave,
        Config::VrrtNoskip,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Config::Raw => "raw",
            Config::Svgf => "svgf",
            Config::SvgfClamp => "svgf-clamp",
            Config::VrrtSuper => "vrrt-super",
            Config::VrrtBalance => "vrrt-balance",
            Config::Vrrt => "vrrt",
            Config::VrrtSave => "vrrt-save",
            Config::VrrtNoskip => "vrrt-noskip",
        }
    }

    /// Denoiser settings for a budget of `rpp` rays per pixel and `signal`. Temporal gradients
    /// are off for signals with reflections, which the gradient prepass cannot re-trace
    /// (`Renderer::new` refuses them).
    pub fn settings(self, rpp: f32, signal: Signal) -> Settings {
        let vrrt = Settings {
            rays_per_pixel: rpp,
            ..Settings::default()
        };
        let mut settings = match self {
            Config::Raw | Config::Svgf => Settings::svgf(rpp),
            Config::SvgfClamp => Settings {
                clamp_radius: 1,
                ..Settings::svgf(rpp)
            },
            Config::VrrtSuper => Settings {
                load_balance: false,
                undersample: false,
                ..vrrt
            },
            Config::VrrtBalance => Settings {
                undersample: false,
                ..vrrt
            },
            Config::Vrrt => vrrt,
            Config::VrrtSave => Settings {
                spend_saved_rays: false,
                ..vrrt
            },
            Config::VrrtNoskip => Settings {
                skip_sigma: 0.0,
                still_sigma: 0.0,
                ..vrrt
            },
        };
        if signal.reflections().is_some() {
            settings.gradient_stratum = 0;
        }
        settings
    }

    /// True when the reported image is the raw samples rather than the denoised output.
    pub fn reports_raw(self) -> bool {
        self == Config::Raw
    }
}
