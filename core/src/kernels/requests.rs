//! The request word: what reprojection asks for each pixel and plane group (a bucket of the ray
//! rate, [`super::buckets`]) and what it found (`FLAG_*`), read by the bucket count, the trim,
//! `apply`, the refill lists and the host. Below them all, so none imports reprojection for it.

/// Flag: no texel of the footprint was valid — history is lost (disocclusion, camera cut).
pub const FLAG_DISOCCLUDED: u32 = 1;
/// Flag: the pixel hit no geometry.
pub const FLAG_SKY: u32 = 2;

/// The word reprojection writes per pixel and plane group: the requested bucket in the low 16
/// bits ([`buckets::NO_RAYS`](super::buckets::NO_RAYS) becomes `0xffff`, still no bucket) and
/// the group's `FLAG_*` in the high 16 bits, so one buffer carries both.
#[inline]
pub fn request_word(bucket: u32, flags: u32) -> u32 {
    let bucket = if bucket < 0xffff { bucket } else { 0xffff };
    bucket | (flags << 16)
}

/// The requested bucket of a [`request_word`] (`0xffff`: none).
#[inline]
pub fn bucket_of(word: u32) -> u32 {
    word & 0xffff
}

/// The `FLAG_*` bits of a [`request_word`].
#[inline]
pub fn flags_of(word: u32) -> u32 {
    word >> 16
}
