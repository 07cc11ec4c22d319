//! The denoiser configurations compared by `run` and `bench` (the baselines and the stages of
//! VRRT) and the denoiser settings each one stands for.

use vrrt_core::settings::Settings;
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
    /// Full VRRT told by an oracle where the converged reference changed since the previous
    /// frame (per pixel and plane, beyond the references' own noise): history is dropped there
    /// as a detected change would drop it, and supersampling follows. The yardstick of
    /// `moving_vs_oracle`; not a bound: changes slower than its per-pixel test stay unseen.
    VrrtOracle,
    /// Full VRRT with the change detector off: what the detector is measured against.
    VrrtNodetect,
}

impl Config {
    /// Every configuration, baselines first.
    pub const ALL: [Config; 10] = [
        Config::Raw,
        Config::Svgf,
        Config::SvgfClamp,
        Config::VrrtSuper,
        Config::VrrtBalance,
        Config::Vrrt,
        Config::VrrtSave,
        Config::VrrtNoskip,
        Config::VrrtOracle,
        Config::VrrtNodetect,
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
            Config::VrrtOracle => "vrrt-oracle",
            Config::VrrtNodetect => "vrrt-nodetect",
        }
    }

    /// Denoiser settings for a budget of `rpp` rays per pixel and `signal`: this configuration's
    /// changes on top of `base` (`Settings::default()`, or a settings file), which they win over.
    /// Temporal gradients are off for signals with reflections, which the gradient prepass cannot
    /// re-trace (`Renderer::new` refuses them), except for the oracle, which re-traces nothing.
    pub fn settings(self, base: Settings, rpp: f32, signal: Signal) -> Settings {
        let mut s = base;
        s.rates.rays_per_pixel = rpp;
        match self {
            Config::Raw | Config::Svgf => s = base.to_svgf(rpp),
            Config::SvgfClamp => {
                s = base.to_svgf(rpp);
                s.temporal.clamp_radius = 1;
            }
            Config::VrrtSuper => {
                s.rates.load_balance = false;
                s.rates.undersample = false;
            }
            Config::VrrtBalance => s.rates.undersample = false,
            Config::Vrrt => {}
            Config::VrrtSave => s.rates.spend_saved_rays = false,
            Config::VrrtNoskip => {
                s.filter.skip_sigma = 0.0;
                s.rates.still_sigma = 0.0;
            }
            Config::VrrtNodetect => s.detector.radius = 0,
            Config::VrrtOracle => {
                // Changes come per pixel, used as given: no reconstruction blur, no gain.
                s.prepass.stratum = 1;
                s.prepass.iterations = 0;
                s.prepass.threshold = 0.5;
                s.prepass.scale = 1.0;
                s.detector.radius = 0;
                // The oracle's drops are true changes: nothing to confirm.
                s.detector.reflection_confirm_sigma = 0.0;
                return s;
            }
        }
        if signal.has_reflections() {
            s.prepass.stratum = 0;
        }
        s
    }

    /// True when the host supplies the changes from the references ([`Config::VrrtOracle`]).
    pub fn is_oracle(self) -> bool {
        self == Config::VrrtOracle
    }

    /// True when the reported image is the raw samples rather than the denoised output.
    pub fn reports_raw(self) -> bool {
        self == Config::Raw
    }
}
