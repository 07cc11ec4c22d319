//! `.gltf` bytes (JSON, data-URI buffers) through `vrrt_scene::load`.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| vrrt_fuzz::load("fuzz.gltf", data));
