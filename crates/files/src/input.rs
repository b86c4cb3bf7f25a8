//! Inputs are regular files. A FIFO where `runs.csv`, `manifest.toml` or a config should be
//! would block a reader forever, a device would never end, and a symlink loop or a dangling
//! link is not "absent": each is refused by name before anything is read.

use crate::error::Error;
use std::path::Path;

/// What kind of thing is at `path`, in words, when it is not a regular file.
fn not_regular(m: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = m.file_type();
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_block_device() || t.is_char_device() {
        "a device"
    } else {
        "not a regular file"
    }
}

/// `Ok(false)` when nothing is at `path` (not even a link), `Ok(true)` when a regular file is
/// (directly or through links); an error naming the path for anything else: a FIFO, socket,
/// device or directory, a symlink loop, a link to nothing.
pub fn regular_file(path: &Path) -> Result<bool, Error> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(Error::io(path, e)),
        Ok(_) => {}
    }
    let m = std::fs::metadata(path).map_err(|e| {
        let why = match e.raw_os_error() {
            Some(40) => "is a symlink loop".to_string(),
            _ if e.kind() == std::io::ErrorKind::NotFound => "is a link to nothing".to_string(),
            _ => e.to_string(),
        };
        Error::io(path, why)
    })?;
    if m.is_file() {
        Ok(true)
    } else {
        Err(Error::io(
            path,
            format!("is {}; an input must be a regular file", not_regular(&m)),
        ))
    }
}

/// The bytes of the regular file at `path` (an error naming it otherwise, or when absent).
pub fn read_regular(path: &Path) -> Result<Vec<u8>, Error> {
    if !regular_file(path)? {
        return Err(Error::io(path, "no such file"));
    }
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// [`read_regular`] as UTF-8 text.
pub fn read_regular_string(path: &Path) -> Result<String, Error> {
    let bytes = read_regular(path)?;
    String::from_utf8(bytes).map_err(|_| Error::io(path, "is not UTF-8 text"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fifos_loops_dangling_links_and_directories_are_refused_by_name() {
        let d = std::env::temp_dir().join(format!("shscale-input-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let f = d.join("ok.csv");
        std::fs::write(&f, "a\n").unwrap();
        assert!(regular_file(&f).unwrap());
        assert_eq!(read_regular_string(&f).unwrap(), "a\n");
        assert!(!regular_file(&d.join("absent")).unwrap());
        let fifo = d.join("fifo.csv");
        let ok = std::process::Command::new("mkfifo").arg(&fifo).status();
        if ok.is_ok_and(|s| s.success()) {
            let e = read_regular(&fifo).unwrap_err().to_string();
            assert!(e.contains("fifo.csv") && e.contains("FIFO"), "{e}");
        }
        let (a, b) = (d.join("a"), d.join("b"));
        std::os::unix::fs::symlink(&b, &a).unwrap();
        std::os::unix::fs::symlink(&a, &b).unwrap();
        let e = regular_file(&a).unwrap_err().to_string();
        assert!(e.contains("symlink loop"), "{e}");
        let dangling = d.join("dangling");
        std::os::unix::fs::symlink(d.join("nothing"), &dangling).unwrap();
        let e = regular_file(&dangling).unwrap_err().to_string();
        assert!(e.contains("link to nothing"), "{e}");
        let e = regular_file(&d).unwrap_err().to_string();
        assert!(e.contains("a directory"), "{e}");
        let e = read_regular(Path::new("/dev/zero"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("a device"), "{e}");
        std::fs::remove_dir_all(&d).ok();
    }
}
