//! Writing entries atomically and safely under concurrency, and cleaning what interrupted
//! writers leave behind.
//!
//! An entry is written to a temporary file `.<entry name>.tmp.<pid>.<n>.<nanos>` in its own
//! directory, flushed to disk, and renamed over the entry. `rename(2)` replaces the name in one
//! step, so a reader sees the old entry or the new one, never a mix, and an interrupted writer
//! never leaves a half-written file under the entry's name.
//!
//! Two writers of the same key need no lock: each writes its own temporary file (the pid, a
//! per-process counter and the clock make the names unique, and `create_new` refuses a clash
//! rather than sharing a file), and each rename is atomic. Whichever rename comes last wins, and
//! both files are complete, checksummed entries of the same key, so every interleaving ends
//! with one valid entry. (On Windows a rename over a file another process has open can fail;
//! that writer reports an error, and the entry in place stays valid.)
//!
//! A writer killed between creating and renaming leaves its temporary file. Every store first
//! removes the temporary files of its directory whose writer is gone: the pid names no live
//! process (known through `/proc` where it exists), or the file is older than [`ORPHAN_AGE`]
//! (pids get reused, and without `/proc` liveness is unknown). Removing a live writer's file by
//! mistake (a pid in another pid namespace sharing the cache, say) is harmless: its rename then
//! fails and it reports that the entry was not stored.

use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, SystemTime};

use super::CacheError;

/// A temporary file older than this is an orphan whatever its pid: writing one entry takes
/// seconds.
pub const ORPHAN_AGE: Duration = Duration::from_secs(10 * 60);

/// Writes `bytes` to `path` via a temporary file in the same directory (see the module docs),
/// after removing orphaned temporary files there.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), CacheError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|source| CacheError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    remove_orphans(dir);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let nanos = SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    let tmp = dir.join(format!(
        ".{name}.tmp.{}.{}.{nanos}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)
    })();
    if let Err(source) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(CacheError::Io {
            path: path.to_path_buf(),
            source,
        });
    }
    // Persist the rename itself where the platform allows opening a directory; best effort.
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Removes the temporary files in `dir` whose writer is gone (best effort: a file that cannot be
/// removed is left for the next store).
fn remove_orphans(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let now = SystemTime::now();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(temp_file_pid) else {
            continue;
        };
        let old = entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| now.duration_since(t).ok())
            .is_some_and(|age| age > ORPHAN_AGE);
        if old || process_gone(pid) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// The writer's pid if `name` is one of our temporary files.
fn temp_file_pid(name: &str) -> Option<u32> {
    let (_, rest) = name.strip_prefix('.')?.rsplit_once(".tmp.")?;
    let mut parts = rest.split('.');
    let pid = parts.next()?.parse().ok()?;
    (parts.count() == 2).then_some(pid)
}

/// True when `pid` is known to name no live process (Linux and others with `/proc`); false when
/// it is alive or unknown.
fn process_gone(pid: u32) -> bool {
    let proc = Path::new("/proc");
    proc.join("self").exists() && !proc.join(pid.to_string()).exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temp_names_parse() {
        assert_eq!(
            temp_file_pid(".f000001_4x4_v1.exr.tmp.1234.5.678"),
            Some(1234)
        );
        assert_eq!(temp_file_pid("f000001_4x4_v1.exr"), None);
        assert_eq!(temp_file_pid(".x.exr.tmp.notapid.5.678"), None);
        assert_eq!(temp_file_pid(".x.exr.tmp.12.5"), None);
        assert!(!process_gone(std::process::id()));
    }
}
