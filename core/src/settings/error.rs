//! The error a setting out of its range gives, apart from the structs it checks.

use core::fmt;

/// A setting out of its range.
#[derive(Clone, Debug, PartialEq)]
pub enum SettingsError {
    /// Width or height is zero, or the image has more than 2^28 pixels (the work list's pixel
    /// index, `kernels::work_list::MAX_PIXELS`).
    Resolution {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
    },
    /// A field outside its documented range.
    OutOfRange {
        /// Field path, stage first (`filter.sigma_luminance`).
        field: &'static str,
        /// Value given (integer fields exactly).
        value: f64,
        /// The range, in words.
        range: &'static str,
    },
}

impl fmt::Display for SettingsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SettingsError::Resolution { width, height } => {
                write!(
                    f,
                    "resolution {width}x{height}: width and height must be at least 1 and the \
                     image at most 2^28 pixels (16384x16384)"
                )
            }
            SettingsError::OutOfRange {
                field,
                value,
                range,
            } => {
                // Integer fields print exactly; a float prints as the `f32` it was.
                // (`fract` is std's: a round trip through an integer, exact below 2^53.)
                if value.abs() < (1u64 << 53) as f64 && (*value as i64) as f64 == *value {
                    write!(f, "setting `{field}` = {value} is out of range ({range})")
                } else {
                    let value = *value as f32;
                    write!(f, "setting `{field}` = {value} is out of range ({range})")
                }
            }
        }
    }
}

impl core::error::Error for SettingsError {}
