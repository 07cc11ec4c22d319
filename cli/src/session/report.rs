//! Averaging and number formatting for the CSV files and tables the subcommands print.

use std::fmt::Write as _;

/// Appends a `,ms_<pass>` column name for every pass in `names`.
pub fn pass_header(s: &mut String, names: &[&str]) {
    for p in names {
        let _ = write!(s, ",ms_{p}");
    }
}

/// Appends the milliseconds of every pass in `names` (0 where it did not run).
pub fn pass_columns(s: &mut String, passes: &[(&'static str, f64)], names: &[&str]) {
    for p in names {
        let ms = passes
            .iter()
            .find(|(n, _)| n == p)
            .map_or(0.0, |(_, ms)| *ms);
        let _ = write!(s, ",{ms:.4}");
    }
}

/// Mean of the finite values (NaN if none).
pub fn mean_finite(values: impl IntoIterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for v in values.into_iter().filter(|v| v.is_finite()) {
        s += v;
        n += 1;
    }
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// Mean of the finite values (NaN if none).
pub fn mean(v: &[f32]) -> f64 {
    mean_finite(v.iter().map(|&x| f64::from(x)))
}

/// Formats a float for CSV and tables (`nan` for NaN).
pub fn fmt(v: f64, digits: usize) -> String {
    if v.is_nan() {
        "nan".into()
    } else {
        format!("{v:.digits$}")
    }
}
