//! File access for paths a user (or a hostile file) names: reads open only regular files and
//! stop at a cap the input kind justifies, writes never follow a symbolic link.
//!
//! Why each rule:
//! - A FIFO or a device opened for reading blocks (a FIFO without a writer) or never ends
//!   (`/dev/zero`). Files are opened non-blocking and refused unless the opened handle is a
//!   regular file, so checking and opening cannot be raced apart.
//! - A read without a cap lets a file (or a link to `/dev/zero`) take all memory: each caller
//!   names the largest size its kind of input can have.
//! - Writing through a name that is a symbolic link writes wherever the link points. Writes go to
//!   a temporary file in the same directory which is then renamed over the name: `rename(2)`
//!   replaces the link itself, and readers never see a half-written file.

use std::fs::File;
use std::io::{self, Read, Write};
use std::path::Path;

/// Prefix of the temporary files [`write_atomic`] creates (and that a crash may leave behind).
pub const TEMP_PREFIX: &str = ".vrrt-tmp-";

/// Why a read failed: the OS error, a path that is not a regular file, or a file past its cap.
#[derive(Debug)]
pub enum ReadError {
    /// Opening or reading failed.
    Io(io::Error),
    /// The path names a FIFO, device, socket or directory.
    NotRegular(&'static str),
    /// The file holds more than `cap` bytes (`len` when its size was known before reading).
    TooLarge {
        /// The cap.
        cap: u64,
        /// The file's size, when known.
        len: Option<u64>,
    },
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::Io(e) => write!(f, "cannot read: {e}"),
            ReadError::NotRegular(kind) => write!(f, "is {kind}, not a regular file"),
            ReadError::TooLarge {
                cap,
                len: Some(len),
            } => {
                write!(f, "is {len} bytes, more than the {cap}-byte limit")
            }
            ReadError::TooLarge { cap, len: None } => {
                write!(f, "holds more than the {cap}-byte limit")
            }
        }
    }
}

impl std::error::Error for ReadError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ReadError::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<ReadError> for io::Error {
    fn from(e: ReadError) -> io::Error {
        match e {
            ReadError::Io(e) => e,
            other => io::Error::new(io::ErrorKind::InvalidInput, other.to_string()),
        }
    }
}

/// What a non-regular file type is, in words.
fn kind_name(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// Opens `path` for reading if (after following links) it is a regular file. The open does not
/// block on a FIFO; the type is checked on the opened handle.
pub fn open_regular(path: &Path) -> Result<File, ReadError> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(ReadError::Io)?;
    let t = file.metadata().map_err(ReadError::Io)?.file_type();
    if !t.is_file() {
        return Err(ReadError::NotRegular(kind_name(t)));
    }
    Ok(file)
}

/// The whole of the regular file `path`, refused if it holds more than `cap` bytes (checked on
/// its size first, then while reading, since files grow).
pub fn read_capped(path: &Path, cap: u64) -> Result<Vec<u8>, ReadError> {
    let file = open_regular(path)?;
    let len = file.metadata().map_err(ReadError::Io)?.len();
    if len > cap {
        return Err(ReadError::TooLarge {
            cap,
            len: Some(len),
        });
    }
    let mut out = Vec::with_capacity(len as usize);
    file.take(cap.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(ReadError::Io)?;
    if out.len() as u64 > cap {
        return Err(ReadError::TooLarge { cap, len: None });
    }
    Ok(out)
}

/// [`read_capped`] as UTF-8 text.
pub fn read_capped_string(path: &Path, cap: u64) -> Result<String, ReadError> {
    String::from_utf8(read_capped(path, cap)?).map_err(|e| {
        ReadError::Io(io::Error::new(
            io::ErrorKind::InvalidData,
            format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        ))
    })
}

/// Writes `bytes` to `path` through a temporary file in the same directory renamed over it, so
/// a symbolic link at `path` is replaced rather than followed, and `path` never holds part of
/// the bytes. New files get the usual permissions (0666 less the umask).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// [`write_atomic`] with the content written by `fill` (buffered).
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = temp_in(path)?;
    let mut w = io::BufWriter::new(tmp);
    fill(&mut w)?;
    let tmp = w.into_inner().map_err(|e| e.into_error())?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// Writes `bytes` to `path` as [`write_atomic`] does and returns the file open for writing more
/// at its end: later writes reach the renamed file, never a link planted at `path` since.
pub fn create_atomic(path: &Path, bytes: &[u8]) -> io::Result<File> {
    let mut tmp = temp_in(path)?;
    tmp.write_all(bytes)?;
    tmp.persist(path).map_err(|e| e.error)
}

/// A new temporary file in `path`'s directory, with the usual permissions of a new file.
fn temp_in(path: &Path) -> io::Result<tempfile::NamedTempFile> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(TEMP_PREFIX);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_and_types() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.txt");
        std::fs::write(&f, b"hello").unwrap();
        assert_eq!(read_capped(&f, 5).unwrap(), b"hello");
        assert!(matches!(
            read_capped(&f, 4),
            Err(ReadError::TooLarge { len: Some(5), .. })
        ));
        assert!(matches!(
            read_capped(dir.path(), 4),
            Err(ReadError::NotRegular("a directory"))
        ));
        #[cfg(unix)]
        assert!(matches!(
            read_capped(Path::new("/dev/zero"), 4),
            Err(ReadError::NotRegular("a device"))
        ));
    }

    #[cfg(unix)]
    #[test]
    fn writes_replace_links_instead_of_following_them() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim");
        std::fs::write(&victim, b"keep").unwrap();
        let link = dir.path().join("out.csv");
        std::os::unix::fs::symlink(&victim, &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
        assert_eq!(std::fs::read(&link).unwrap(), b"new");
        assert!(!std::fs::symlink_metadata(&link).unwrap().is_symlink());
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(left.len(), 2, "no temporary file is left");
    }
}
