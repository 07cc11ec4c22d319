//! Output directories that hold only the latest run's files: before writing, a command removes
//! what an earlier run of it wrote there (files matching its own name patterns, nothing else), so
//! a shorter run does not leave an earlier run's frames beside its own.

use anyhow::{Context, Result};
use std::path::Path;

/// Creates `dir` and removes the plain files in it (not in subdirectories) whose names match
/// one of `patterns` (`*` matches any run of characters); says how many on stderr.
pub fn prepare(dir: &Path, patterns: &[&str]) -> Result<usize> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()))?;
    let mut removed = 0;
    for entry in entries {
        let entry = entry.with_context(|| format!("cannot list {}", dir.display()))?;
        let stale = entry.file_type().is_ok_and(|t| t.is_file())
            && entry
                .file_name()
                .to_str()
                .is_some_and(|n| patterns.iter().any(|p| glob(p, n)));
        if stale {
            let path = entry.path();
            std::fs::remove_file(&path)
                .with_context(|| format!("cannot remove {}", path.display()))?;
            removed += 1;
        }
    }
    if removed > 0 {
        eprintln!(
            "removed {removed} files of an earlier run from {} ({})",
            dir.display(),
            patterns.join(", ")
        );
    }
    Ok(removed)
}

/// Whether `name` matches `pattern`, where `*` matches any run of characters.
fn glob(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == name,
        Some((head, rest)) => {
            let Some(name) = name.strip_prefix(head) else {
                return false;
            };
            name.char_indices()
                .map(|(i, _)| i)
                .chain([name.len()])
                .any(|i| glob(rest, &name[i..]))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_match_whole_names() {
        assert!(glob("frame*_*.png", "frame0007_ao_denoised.png"));
        assert!(glob("frames.csv", "frames.csv"));
        assert!(glob("denoised_last*.exr", "denoised_last.exr"));
        assert!(!glob("frames.csv", "frames.csv.bak"));
        assert!(!glob("frame*_*.png", "frame0007_raw.png.txt"));
        assert!(!glob("frame*_*.png", "myframe0001_raw.png"));
        assert!(!glob("frame*_*.png", "frame0001.png"));
    }

    #[test]
    fn only_matching_plain_files_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for f in ["frame0001_raw.png", "frames.csv", "notes.txt", "frame.png"] {
            std::fs::write(d.join(f), b"x").unwrap();
        }
        std::fs::create_dir(d.join("frame0002_dir.png")).unwrap();
        assert_eq!(prepare(d, &["frame*_*.png", "frames.csv"]).unwrap(), 2);
        assert!(d.join("notes.txt").is_file());
        assert!(d.join("frame.png").is_file());
        assert!(d.join("frame0002_dir.png").is_dir());
        assert!(!d.join("frames.csv").exists());
    }
}
