//! What `run`, `reference` and `bench` share: parsing of sizes, scenes, signals and denoiser
//! configurations, cached references, and the render-and-measure loop over a frame sequence.
//!
//! The submodules are private and everything is re-exported here, so the subcommands import
//! from `crate::session` whatever module an item lives in.

mod config;
mod images;
mod parse;
mod record;
mod recycle;
mod references;
mod report;
mod sequence;
mod setup;
mod signal;

pub use config::Config;
pub use images::{
    fresh_mask, moving_mask, oracle_changes, planes_to_image, MOVING_THRESHOLD, ORACLE_SIGMAS,
};
pub use parse::{parse_backend, parse_budget_ms, parse_rpp, parse_size, MAX_DIMENSION};
pub use record::{
    Detection, FrameRecord, FrameView, PartFrame, PartMetrics, SequenceResult, WARMUP_FRAMES,
};
pub use references::{FrameReference, ReferenceRequest, References, REFERENCE_VERSION};
pub use report::{fmt, mean, mean_finite, pass_columns, pass_header};
pub use sequence::{run_sequence, SequenceOptions};
pub use setup::{load_scene, open_backend, LoadedScene};
pub use signal::{parts, plane_names, Part, SignalArg};
