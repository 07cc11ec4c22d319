//! # vrrt-scene
//!
//! Everything on the host side of a frame that is not a backend: scenes (built-in procedural ones
//! and loaded meshes), the BVH builder that flattens them into `vrrt_core::trace`'s layout,
//! animation, ground-truth references, error metrics and image IO.

pub mod image;
pub mod metrics;
pub mod reference_cache;
