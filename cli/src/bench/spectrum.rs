//! The error power spectra of the bench cells: four `bench.csv` columns and `spectrum.csv`.

use super::Cell;
use crate::session::{fmt, FrameRecord};
use std::fmt::Write as _;
#[cfg(doc)]
use vrrt_scene::metrics::LOW_BAND;
use vrrt_scene::metrics::{ErrorSpectrum, RADIAL_BINS};

/// Mean of one spectrum over the measured frames (those with a relMSE).
pub fn mean(
    records: &[FrameRecord],
    spectrum: fn(&FrameRecord) -> &ErrorSpectrum,
) -> ErrorSpectrum {
    ErrorSpectrum::mean(records.iter().filter(|r| !r.relmse.is_nan()).map(spectrum))
}

/// `raw_relmse,error_lowfreq_fraction,error_low_mse,raw_lowfreq_fraction,raw_low_mse` of `c`.
pub fn columns(c: &Cell) -> String {
    format!(
        "{},{},{},{},{}",
        fmt(c.raw_relmse, 7),
        fmt(c.error_spectrum.low_fraction(), 4),
        fmt(c.error_spectrum.low, 7),
        fmt(c.raw_spectrum.low_fraction(), 4),
        fmt(c.raw_spectrum.low, 7)
    )
}

/// `spectrum.csv`: per cell and image (`denoised` or `raw`), the error's DC, band powers (low:
/// radius below [`LOW_BAND`] cycles per pixel) and radially averaged power spectrum; bin `i` covers radii `[i, i + 1) · √½ / RADIAL_BINS` cycles
/// per pixel.
pub fn csv(cells: &[Cell]) -> String {
    let mut s =
        String::from("scene,signal,config,budget_rpp,backend,image,dc,low,high,low_fraction");
    for i in 0..RADIAL_BINS {
        let _ = write!(s, ",r{i}");
    }
    s.push('\n');
    for c in cells {
        for (image, sp) in [("denoised", &c.error_spectrum), ("raw", &c.raw_spectrum)] {
            let _ = write!(
                s,
                "{},{image},{},{},{},{}",
                c.key(","),
                fmt(sp.dc, 7),
                fmt(sp.low, 7),
                fmt(sp.high, 7),
                fmt(sp.low_fraction(), 4)
            );
            for p in &sp.radial {
                let _ = write!(s, ",{}", fmt(*p, 7));
            }
            s.push('\n');
        }
    }
    s
}
