//! The `--max-*` flags: the resource limits a user's mesh file is loaded under
//! ([`LoadLimits`]), shared by `run`, `reference` and `bench`.

use vrrt_scene::load::LoadLimits;

/// Limits on a mesh file given as `--scene`. The defaults are [`LoadLimits::default`] (a unit
/// test holds them equal); sizes take plain bytes or a binary suffix (`512M`, `2G`).
#[derive(Clone, Debug, clap::Args)]
pub struct LimitArgs {
    /// Largest mesh file (and glTF buffer file) read, in bytes or with a suffix K, M, G, T
    /// (powers of 1024).
    #[arg(long, value_name = "SIZE", default_value = "1G", value_parser = parse_bytes)]
    pub max_file_size: u64,
    /// Largest size of a `.ply.gz` after inflation (bytes, or K, M, G, T).
    #[arg(long, value_name = "SIZE", default_value = "1G", value_parser = parse_bytes)]
    pub max_decompressed: u64,
    /// Most vertices of a mesh file.
    #[arg(long, value_name = "N", default_value = "8388608", value_parser = parse_count)]
    pub max_vertices: u64,
    /// Most triangles of a mesh file (after polygons are split into triangles).
    #[arg(long, value_name = "N", default_value = "8388608", value_parser = parse_count)]
    pub max_triangles: u64,
    /// Largest BVH built over a mesh file (bytes, or K, M, G, T).
    #[arg(long, value_name = "SIZE", default_value = "2G", value_parser = parse_bytes)]
    pub max_bvh_memory: u64,
}

impl LimitArgs {
    /// The limits these flags set.
    pub fn limits(&self) -> LoadLimits {
        LoadLimits {
            max_file_size: self.max_file_size,
            max_decompressed_size: self.max_decompressed,
            max_vertices: self.max_vertices,
            max_triangles: self.max_triangles,
            max_bvh_bytes: self.max_bvh_memory,
        }
    }
}

/// Parses a size in bytes: a whole number, optionally followed by `K`, `M`, `G` or `T` (powers
/// of 1024, any case, `KiB`/`KB` spellings too). Zero is refused: it would refuse every file.
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let digits = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (number, suffix) = t.split_at(digits);
    if number.is_empty() {
        return Err(format!(
            "`{s}` is not a size: expected bytes, or a number with K, M, G or T (e.g. 512M)"
        ));
    }
    let shift = match suffix.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 0,
        "K" | "KB" | "KIB" => 10,
        "M" | "MB" | "MIB" => 20,
        "G" | "GB" | "GIB" => 30,
        "T" | "TB" | "TIB" => 40,
        _ => {
            return Err(format!(
                "`{s}`: unknown size suffix `{}` (expected K, M, G or T)",
                suffix.trim()
            ))
        }
    };
    let n: u64 = number
        .parse()
        .map_err(|_| format!("`{s}` is too large a size"))?;
    let bytes = n
        .checked_mul(1 << shift)
        .ok_or_else(|| format!("`{s}` is too large a size"))?;
    if bytes == 0 {
        return Err("a size limit must be at least 1 byte".into());
    }
    Ok(bytes)
}

/// Parses a count limit: a whole number of at least 1.
pub fn parse_count(s: &str) -> Result<u64, String> {
    match s.trim().parse::<u64>() {
        Ok(0) => Err("a count limit must be at least 1".into()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!("`{s}` is not a whole number")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        limits: LimitArgs,
    }

    #[test]
    fn defaults_are_the_library_defaults() {
        let cli = Cli::try_parse_from(["vrrt"]).unwrap();
        assert_eq!(cli.limits.limits(), LoadLimits::default());
    }

    #[test]
    fn sizes_take_bytes_and_binary_suffixes() {
        assert_eq!(parse_bytes("4096"), Ok(4096));
        assert_eq!(parse_bytes("512M"), Ok(512 << 20));
        assert_eq!(parse_bytes("2G"), Ok(2 << 30));
        assert_eq!(parse_bytes("3kib"), Ok(3 << 10));
        assert_eq!(parse_bytes(" 1 T "), Ok(1 << 40));
        assert!(parse_bytes("").unwrap_err().contains("not a size"));
        assert!(parse_bytes("G").unwrap_err().contains("not a size"));
        assert!(parse_bytes("-1").unwrap_err().contains("not a size"));
        assert!(parse_bytes("1.5G").unwrap_err().contains("suffix `.5G`"));
        assert!(parse_bytes("5X").unwrap_err().contains("suffix `X`"));
        assert!(parse_bytes("0").unwrap_err().contains("at least 1"));
        assert!(parse_bytes("16777216T").unwrap_err().contains("too large"));
        assert!(parse_bytes("99999999999999999999")
            .unwrap_err()
            .contains("too large"));
        assert_eq!(parse_count("12"), Ok(12));
        assert!(parse_count("0").unwrap_err().contains("at least 1"));
        assert!(parse_count("1k").unwrap_err().contains("whole number"));
    }
}
