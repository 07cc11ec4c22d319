//! `.ply.gz` through `vrrt_scene::load`. The first byte picks what the rest is: even, the
//! gzipped file as is (the gzip header, deflate stream and CRC are fuzzed); odd, a PLY file that
//! is gzipped here first (the PLY parser behind the inflater and the decompressed-size limit).
#![no_main]
use std::io::Write;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    if mode % 2 == 0 {
        vrrt_fuzz::load("fuzz.ply.gz", rest);
    } else {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all(rest).unwrap();
        vrrt_fuzz::load("fuzz.ply.gz", &enc.finish().unwrap());
    }
});
