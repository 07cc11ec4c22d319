//! The denoiser's buffers as sizes, before any is allocated: so a size that cannot fit the
//! device is refused with the limit, the buffer and the largest size that fits — before any
//! work starts — and so memory can be reported per buffer.

use crate::camera::View;
use crate::executor::BindingLimit;
use crate::kernels::gradient::GradientSample;
use crate::kernels::work_list::ARGS_LEN;
use crate::kernels::{balance, buckets, classify, refill, reflect, trim};
use crate::layout::Layout;
use crate::payload::{PackedFiltered, PackedPayload, PackedSample, COUNTERS_LEN};
use crate::settings::Settings;
use core::fmt;
use core::mem::size_of;

/// How many of each buffer the denoiser keeps, and the bytes of one.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct BufferSize {
    /// Buffer name (the `Denoiser` accessor that returns it).
    pub name: &'static str,
    /// Copies kept (ping-pong pairs have 2).
    pub count: u32,
    /// Bytes of one copy.
    pub bytes: u64,
    /// Element type, as the kernels declare it (`kernels::names::format_of` gives its format).
    pub ty: &'static str,
}

const fn size(name: &'static str, count: u32, bytes: u64, ty: &'static str) -> BufferSize {
    BufferSize {
        name,
        count,
        bytes,
        ty,
    }
}

/// How many distinct buffers (ping-pong pairs counted once) a `Denoiser` allocates.
pub const DENOISER_BUFFERS: usize = 31;

/// Gradient cells across and down for stratum size `stratum` (one dummy cell when off).
pub fn grid_size(width: u32, height: u32, stratum: u32) -> (u32, u32) {
    if stratum == 0 {
        (1, 1)
    } else {
        (width.div_ceil(stratum), height.div_ceil(stratum))
    }
}

/// Elements of the buffers only some configurations need (one element where not needed).
struct Guides {
    parallax: u64,
    guide: u64,
    penumbra: u64,
    ao_guide: u64,
    ao_guide_raw: u64,
}

/// [`Guides`] of a `width × height` denoiser with `layout` and `settings`: reflection parallax
/// positions exist only with a parallax plane, the hit-distance guide with a guide plane, the
/// shadow raygen's blocker records and the penumbra guide with a penumbra plane, the AO guide
/// (two pixels a word) with AO planes and the guide on, and its raw fractions, kept across
/// frames (this frame's and last frame's), when it refreshes (otherwise a frame's go to a
/// filter buffer).
fn guides(width: u32, height: u32, layout: &Layout, settings: &Settings) -> Guides {
    let pixels = width as u64 * height as u64;
    let only = |needed: bool, elements: u64| if needed { elements } else { 1 };
    let ao = layout.ao_planes != 0 && settings.filter.ao_guide_directions > 0;
    let words = crate::kernels::ao_guide::guide_row_words(width) as u64 * height as u64;
    Guides {
        parallax: only(layout.parallax_plane.is_some(), pixels),
        guide: only(layout.guide_plane.is_some(), pixels),
        penumbra: only(layout.penumbra_plane.is_some(), pixels),
        ao_guide: only(ao, words),
        ao_guide_raw: only(ao && settings.filter.ao_guide_refresh > 0, pixels),
    }
}

/// Every buffer a `Denoiser` of `width × height` with `layout` and `settings` allocates, in
/// allocation order.
pub fn denoiser_buffers(
    width: u32,
    height: u32,
    layout: &Layout,
    settings: &Settings,
) -> [BufferSize; DENOISER_BUFFERS] {
    let pixels = width as u64 * height as u64;
    let planes = pixels * layout.planes as u64;
    let groups = layout.groups() as u64;
    let (gw, gh) = grid_size(width, height, settings.prepass.stratum);
    let cells = gw as u64 * gh as u64;
    let gradient = cells * layout.planes as u64 * size_of::<GradientSample>() as u64;
    let (tw, th) = classify::tile_grid(width, height);
    let (rw, rh) = reflect::tile_grid(width, height);
    let bytes = |n: u64, elem: usize| n * elem as u64;
    let Guides {
        parallax,
        guide,
        penumbra,
        ao_guide,
        ao_guide_raw,
    } = guides(width, height, layout, settings);
    [
        size("noise", 1, bytes(crate::blue_noise::LEN as u64, 4), "f32"),
        size("counters", 1, bytes(COUNTERS_LEN as u64, 4), "u32"),
        // The engine's inputs; the second copy of depth and normal is last frame's, kept by the
        // denoiser for reprojection.
        size("depth", 2, bytes(pixels, 4), "Depth"),
        size("normal_roughness", 2, bytes(pixels, 4), "NormalRoughness"),
        size("motion", 1, bytes(pixels, 8), "Motion"),
        size("view", 1, size_of::<View>() as u64, "View"),
        size(
            "conventions",
            1,
            size_of::<crate::inputs::IngestParams>() as u64,
            "IngestParams",
        ),
        size(
            "history",
            2,
            bytes(planes, size_of::<PackedPayload>()),
            "PackedPayload",
        ),
        size(
            "samples",
            1,
            bytes(planes, size_of::<PackedSample>()),
            "PackedSample",
        ),
        // The filter's ping-pong and output; the copy the output does not end in also holds the
        // work list between apply and raygen (one `u32` per pixel, at most).
        size(
            "filtered",
            2,
            bytes(planes, size_of::<PackedFiltered>()),
            "PackedFiltered",
        ),
        // The engine's optional VRS mask.
        size(
            "mask",
            1,
            bytes(if settings.rates.vrs_mask { pixels } else { 1 }, 4),
            "VrsMask",
        ),
        size("requests", 1, bytes(pixels * groups, 4), "Request"),
        size(
            "counts",
            1,
            bytes(groups * buckets::COUNTS_LEN as u64, 4),
            "u32",
        ),
        size(
            "decision",
            1,
            bytes(groups, size_of::<balance::Balance>()),
            "Balance",
        ),
        size("trim", 1, bytes(groups * trim::HIST_LEN as u64, 4), "u32"),
        size(
            "refill_hist",
            1,
            bytes(groups * refill::FIT_BINS as u64, 4),
            "u32",
        ),
        size("args", 1, bytes(groups * ARGS_LEN as u64, 4), "u32"),
        // The refill lists' arguments: this frame's, read by the next frame's balancer
        // (`balance::refill_reserve`).
        size("refill_args", 1, bytes(groups * ARGS_LEN as u64, 4), "u32"),
        size("gradient_keys", 1, bytes(cells, 4), "GradientKey"),
        size("gradient_raw", 1, gradient, "GradientSample"),
        size("gradient", 2, gradient, "GradientSample"),
        size("tiles", 1, bytes(tw as u64 * th as u64, 4), "TileWord"),
        size(
            "tile_histogram",
            1,
            bytes(classify::HISTOGRAM_LEN as u64, 4),
            "u32",
        ),
        size("importance", 1, bytes(rw as u64 * rh as u64, 4), "f32"),
        size("parallax", 1, bytes(parallax, 8), "[f32; 2]"),
        size("guide", 1, bytes(guide, 4), "f32"),
        size("blockers", 1, bytes(penumbra, 4), "f32"),
        size("penumbra", 1, bytes(penumbra, 4), "f32"),
        size("ao_guide", 1, bytes(ao_guide, 4), "u32"),
        size("ao_guide_raw", 2, bytes(ao_guide_raw, 4), "u32"),
        // Bound in place of a buffer a pass does not read in this configuration (accumulation's
        // surfaces without an own-surface clamp), so the pass neither waits on nor counts the
        // bytes it skips; two, since a pass binds each buffer once.
        size("unread", 2, 16, "u32"),
    ]
}

/// A size whose buffers do not fit the device.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct TooLarge {
    /// The size asked for.
    pub size: (u32, u32),
    /// The first buffer over the limit.
    pub buffer: &'static str,
    /// Its bytes.
    pub bytes: u64,
    /// The device's limit.
    pub limit: BindingLimit,
    /// The largest size of the same aspect ratio whose buffers all fit (`None`: not even 1×1).
    pub fits: Option<(u32, u32)>,
}

impl fmt::Display for TooLarge {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (w, h) = self.size;
        write!(
            f,
            "{w}x{h} does not fit the device: the denoiser's buffer `{}` needs {} bytes, more \
             than {} ({} bytes)",
            self.buffer, self.bytes, self.limit.name, self.limit.bytes
        )?;
        match self.fits {
            Some((fw, fh)) => write!(
                f,
                "; the largest size of this aspect ratio that fits is {fw}x{fh}"
            ),
            None => write!(f, "; no size fits"),
        }
    }
}

/// The first buffer of `sizes(width, height)` larger than `limit`, if any.
fn over_limit(
    sizes: &impl Fn(u32, u32) -> [BufferSize; DENOISER_BUFFERS],
    width: u32,
    height: u32,
    limit: BindingLimit,
) -> Option<BufferSize> {
    sizes(width, height)
        .into_iter()
        .find(|b| b.bytes > limit.bytes)
}

/// Checks every buffer of a `width × height` denoiser against `limit`; on failure, finds the
/// largest size of the same aspect ratio that fits (buffers grow with the pixel count, so the
/// search is a bisection on the scale).
pub fn check_fit(
    width: u32,
    height: u32,
    layout: &Layout,
    settings: &Settings,
    limit: BindingLimit,
) -> Result<(), TooLarge> {
    let sizes = |w: u32, h: u32| denoiser_buffers(w, h, layout, settings);
    let Some(first) = over_limit(&sizes, width, height, limit) else {
        return Ok(());
    };
    let scaled = |s: u32| {
        let w = (width as u64 * s as u64 / 4096).max(1) as u32;
        let h = (height as u64 * s as u64 / 4096).max(1) as u32;
        (w, h)
    };
    // Largest scale s/4096 in [1, 4096) whose size fits; scale 0 stands for 1×1.
    let (mut lo, mut hi) = (0u32, 4096u32);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        let (w, h) = scaled(mid);
        if over_limit(&sizes, w, h, limit).is_some() {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let (w, h) = scaled(lo);
    Err(TooLarge {
        size: (width, height),
        buffer: first.name,
        bytes: first.bytes,
        limit,
        fits: over_limit(&sizes, w, h, limit).is_none().then_some((w, h)),
    })
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::kernels::names::format_of;
    use std::string::ToString;

    const LAVAPIPE: BindingLimit = BindingLimit {
        bytes: 128 << 20,
        name: "maxStorageBufferRange",
    };

    #[test]
    fn oversized_request_names_buffer_limit_and_what_fits() {
        let s = Settings::default();
        assert_eq!(
            check_fit(1920, 1080, &Layout::default(), &s, LAVAPIPE),
            Ok(())
        );
        assert_eq!(
            check_fit(3840, 2160, &Layout::default(), &s, LAVAPIPE),
            Ok(())
        );
        let e = check_fit(7680, 4320, &Layout::default(), &s, LAVAPIPE).unwrap_err();
        assert_eq!(e.buffer, "motion");
        assert!(e.bytes > LAVAPIPE.bytes);
        let (w, h) = e.fits.expect("something fits");
        assert!(check_fit(w, h, &Layout::default(), &s, LAVAPIPE).is_ok());
        // Largest: one step up of the same aspect does not fit.
        assert!(check_fit(w + 2, h + 2, &Layout::default(), &s, LAVAPIPE).is_err());
        let msg = e.to_string();
        assert!(
            msg.contains("maxStorageBufferRange") && msg.contains("`motion`"),
            "{msg}"
        );
    }

    #[test]
    fn sizes_match_the_pixel_count() {
        let s = Settings::default();
        let b = denoiser_buffers(100, 50, &Layout::default(), &s);
        let depth = b.iter().find(|b| b.name == "depth").unwrap();
        assert_eq!(depth.bytes, 5000 * 4);
        assert_eq!(depth.count, 2);
    }

    #[test]
    fn every_buffer_names_a_declared_format() {
        for b in denoiser_buffers(64, 32, &Layout::default(), &Settings::default()) {
            assert!(format_of(b.ty).is_some(), "{}: `{}`", b.name, b.ty);
        }
    }
}
