//! OBJ bytes through `vrrt_scene::load` (a valid mesh or a typed error; never a panic).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| vrrt_fuzz::load("fuzz.obj", data));
