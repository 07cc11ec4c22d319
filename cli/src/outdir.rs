//! Output directories that hold only the latest run's files, and nothing else of the user's is
//! touched.
//!
//! A command records every file it writes in a manifest inside the directory
//! (`.vrrt-<command>-manifest`, a name a line) *before* writing the file, so even an interrupted
//! run leaves a manifest that covers its files. The next run of the command removes exactly the
//! files its manifest names and starts a new one: a user's file is never removed, whatever its
//! name, and a shorter run does not leave an earlier run's frames beside its own.
//!
//! Files are written through a temporary file renamed over the name
//! ([`vrrt_scene::safe_fs::write_atomic`]), so a symbolic link planted in the directory is
//! replaced, never written through. Whether the directory is writable is found when it is
//! prepared, before anything is removed or rendered.

use anyhow::{anyhow, bail, Context, Result};
use std::cell::RefCell;
use std::collections::HashSet;
use std::fs::File;
use std::io::Write as _;
use std::path::{Component, Path, PathBuf};
use std::time::{Duration, SystemTime};
use vrrt_scene::safe_fs::{self, TEMP_PREFIX};

/// Largest manifest read back: far more names than any run writes.
const MAX_MANIFEST: u64 = 16 << 20;

/// A temporary file older than this is left over from a killed run (a live write takes
/// seconds), and is removed; a younger one may belong to a concurrent run.
const ORPHAN_AGE: Duration = Duration::from_secs(10 * 60);

/// An output directory prepared for one command's run.
pub struct OutDir {
    dir: PathBuf,
    manifest: RefCell<File>,
    recorded: RefCell<HashSet<String>>,
}

impl OutDir {
    /// Creates `dir` if needed, checks that files can be written in it, removes the files the
    /// last run of `command` listed in its manifest (plain files and links, never directories)
    /// and starts this run's manifest. Says on stderr how many files were removed.
    pub fn prepare(dir: &Path, command: &str) -> Result<OutDir> {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the output directory {}", dir.display()))?;
        if !dir.is_dir() {
            bail!("the output directory {} is not a directory", dir.display());
        }
        check_writable(dir)?;
        remove_orphans(dir);
        let manifest = dir.join(format!(".vrrt-{command}-manifest"));
        let removed = remove_listed(dir, &manifest)?;
        if removed > 0 {
            eprintln!(
                "removed {removed} files an earlier `vrrt {command}` wrote in {}",
                dir.display()
            );
        }
        let header = format!(
            "# Files `vrrt {command}` wrote in this directory; its next run removes them (and \
             nothing else).\n"
        );
        let file = safe_fs::create_atomic(&manifest, header.as_bytes())
            .with_context(|| format!("cannot write {}", manifest.display()))?;
        Ok(OutDir {
            dir: dir.to_path_buf(),
            manifest: RefCell::new(file),
            recorded: RefCell::new(HashSet::new()),
        })
    }

    /// The directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The path of `name` (a file name, or `subdir/file`) in the directory, recorded in the
    /// manifest before it is returned; `subdir` is created, and must be a real directory.
    pub fn file(&self, name: &str) -> Result<PathBuf> {
        if !valid_name(name) {
            bail!("internal: `{name}` is not an output file name");
        }
        let path = self.dir.join(name);
        if let Some((sub, _)) = name.split_once('/') {
            let sub = self.dir.join(sub);
            match std::fs::symlink_metadata(&sub) {
                Ok(m) if m.is_dir() => {}
                Ok(_) => bail!(
                    "{} is not a directory (a link or a file): refusing to write into it",
                    sub.display()
                ),
                Err(_) => std::fs::create_dir(&sub)
                    .with_context(|| format!("cannot create {}", sub.display()))?,
            }
        }
        if self.recorded.borrow_mut().insert(name.to_string()) {
            writeln!(self.manifest.borrow_mut(), "{name}").with_context(|| {
                format!(
                    "cannot record {name} in the manifest of {}",
                    self.dir.display()
                )
            })?;
        }
        Ok(path)
    }

    /// Writes `bytes` as `name` (see [`file`](Self::file)), atomically.
    pub fn write(&self, name: &str, bytes: &[u8]) -> Result<PathBuf> {
        let path = self.file(name)?;
        safe_fs::write_atomic(&path, bytes)
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(path)
    }
}

/// Fails, naming the directory, unless a file can be created in it.
fn check_writable(dir: &Path) -> Result<()> {
    tempfile::Builder::new()
        .prefix(TEMP_PREFIX)
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| {
            anyhow!(
                "the output directory {} is not writable: {e}",
                dir.display()
            )
        })
}

/// Whether `name` is one an [`OutDir`] writes: a file name or `subdir/file`, no `..`, no root.
fn valid_name(name: &str) -> bool {
    let path = Path::new(name);
    let parts: Vec<Component> = path.components().collect();
    !name.contains(['\n', '\r', '\\'])
        && (1..=2).contains(&parts.len())
        && parts.len() == name.split('/').count()
        && parts.iter().all(|c| matches!(c, Component::Normal(_)))
}

/// Removes the files the manifest at `manifest` names; returns how many. A manifest that is
/// missing, a link or not text is taken as empty: nothing is removed on its word.
fn remove_listed(dir: &Path, manifest: &Path) -> Result<usize> {
    let is_file = std::fs::symlink_metadata(manifest).is_ok_and(|m| m.is_file());
    if !is_file {
        return Ok(0);
    }
    let Ok(text) = safe_fs::read_capped_string(manifest, MAX_MANIFEST) else {
        return Ok(0);
    };
    let mut removed = 0;
    for name in text.lines().filter(|l| !l.starts_with('#')) {
        if !valid_name(name) {
            continue;
        }
        // A subdirectory replaced by a link since would lead the removal out of `dir`.
        if let Some((sub, _)) = name.split_once('/') {
            if !std::fs::symlink_metadata(dir.join(sub)).is_ok_and(|m| m.is_dir()) {
                continue;
            }
        }
        let path = dir.join(name);
        let plain = std::fs::symlink_metadata(&path).is_ok_and(|m| !m.is_dir());
        if plain {
            std::fs::remove_file(&path)
                .with_context(|| format!("cannot remove {}", path.display()))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Removes temporary files a killed run left (older than [`ORPHAN_AGE`]); best effort.
fn remove_orphans(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let now = SystemTime::now();
    for entry in entries.flatten() {
        let ours = entry
            .file_name()
            .to_str()
            .is_some_and(|n| n.starts_with(TEMP_PREFIX));
        let old = entry
            .metadata()
            .ok()
            .filter(|m| m.is_file())
            .and_then(|m| m.modified().ok())
            .and_then(|t| now.duration_since(t).ok())
            .is_some_and(|age| age > ORPHAN_AGE);
        if ours && old {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_stay_inside_the_directory() {
        assert!(valid_name("frames.csv"));
        assert!(valid_name("report/s001_f0004_vrrt.png"));
        for bad in [
            "",
            "..",
            "../x",
            "/etc/passwd",
            "a/b/c",
            "a//b",
            "./x",
            "a/",
            "x\ny",
            "a/..",
        ] {
            assert!(!valid_name(bad), "{bad:?}");
        }
    }

    #[test]
    fn only_the_last_runs_files_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("frame0001_notes.png"), b"user").unwrap();
        let out = OutDir::prepare(d, "run").unwrap();
        out.write("frames.csv", b"a").unwrap();
        out.write("report/x.png", b"b").unwrap();
        drop(out);
        std::fs::write(d.join("report/user.png"), b"user").unwrap();
        let out = OutDir::prepare(d, "run").unwrap();
        assert!(!d.join("frames.csv").exists());
        assert!(!d.join("report/x.png").exists());
        assert!(d.join("frame0001_notes.png").is_file());
        assert!(d.join("report/user.png").is_file());
        // Another command's manifest is its own.
        out.write("frames.csv", b"c").unwrap();
        drop(OutDir::prepare(d, "bench").unwrap());
        assert!(d.join("frames.csv").is_file());
    }

    #[test]
    fn a_hostile_manifest_removes_nothing_outside() {
        let dir = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        let victim = outside.path().join("victim.txt");
        std::fs::write(&victim, b"keep").unwrap();
        let d = dir.path().join("out");
        std::fs::create_dir(&d).unwrap();
        let listed = format!("../victim.txt\n{}\n/etc/passwd\n", victim.display());
        std::fs::write(d.join(".vrrt-run-manifest"), listed).unwrap();
        drop(OutDir::prepare(&d, "run").unwrap());
        assert!(victim.is_file());
        // A listed file under a subdirectory that became a link out of the directory.
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(outside.path(), d.join("report")).unwrap();
            std::fs::write(d.join(".vrrt-run-manifest"), "report/victim.txt\n").unwrap();
            drop(OutDir::prepare(&d, "run").unwrap());
            assert!(victim.is_file());
        }
    }
}
