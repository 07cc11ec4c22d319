//! Command-line value parsers (`value_parser`s) for sizes, ray budgets and backends, with the
//! range checks that turn a bad argument into a one-line error before anything runs.

use vrrt_backend::BackendKind;

/// Largest accepted width or height.
pub const MAX_DIMENSION: u32 = 8192;

/// Parses `WxH` (e.g. `256x144`); both must be in `1..=MAX_DIMENSION`.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not a size: expected WxH, e.g. 256x144");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 {
        return Err(format!("size {w}x{h}: width and height must be at least 1"));
    }
    if w > MAX_DIMENSION || h > MAX_DIMENSION {
        return Err(format!(
            "size {w}x{h}: width and height must be at most {MAX_DIMENSION}"
        ));
    }
    Ok((w, h))
}

/// Parses a ray budget in rays per pixel per frame: `0 < rpp <= 16`.
pub fn parse_rpp(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number of rays per pixel"))?;
    if !(v > 0.0 && v <= 16.0) {
        return Err(format!(
            "ray budget {v} rays per pixel is out of range (0 < rpp <= 16)"
        ));
    }
    Ok(v)
}

/// Parses a backend name (`auto`, `cpu`, `wgpu`, `ash`).
pub fn parse_backend(s: &str) -> Result<BackendKind, String> {
    s.parse()
}

/// Parses a ray budget in milliseconds of tracing per frame (0 = off; at most 1000).
pub fn parse_budget_ms(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number of milliseconds"))?;
    if !(0.0..=1000.0).contains(&v) {
        return Err(format!(
            "ray budget of {v} ms is out of range (0 = off, or 0 < ms <= 1000)"
        ));
    }
    Ok(v)
}
