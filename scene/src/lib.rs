//! # vrrt-scene
//!
//! Everything on the host side of a frame that is not a backend: scenes (built-in procedural ones
//! and loaded meshes), the BVH builder that flattens them into `vrrt_core::trace`'s layout,
//! animation, ground-truth references, error metrics and image IO.

pub mod animation;
pub mod builtin;
pub mod bvh;
pub mod error;
pub mod events;
pub mod image;
pub mod load;
pub mod mesh;
pub mod mesh_cache;
pub mod mesh_scenes;
pub mod metrics;
pub mod reference_cache;
pub mod render;
pub mod safe_fs;
pub mod scene;
pub mod shapes;
pub mod thicket;

pub use error::SceneError;
pub use events::{Event, EventKind};
pub use mesh::Mesh;
pub use scene::{FrameGeometry, Scene};
