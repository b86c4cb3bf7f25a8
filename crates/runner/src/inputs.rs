//! Inputs by content: every file a run reads (a mesh, a scene and the meshes and environment
//! maps it names) and every bundled asset it reads by name is hashed with BLAKE3 at plan time;
//! the hashes identify the run's rows together with its parameters and the numerical
//! fingerprint (docs/provenance.md). Files are hashed once per process and content: the cache
//! is keyed by path, size and modification time, so a plan of 10⁵ runs naming one mesh hashes it
//! once and then costs a `stat` per run.

use crate::error::Error;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// One input a run reads, declared by its kind ([`crate::Kind::inputs`]).
#[derive(Clone, Debug)]
pub enum Input {
    /// A file, as the run opens it; `key` is the parameter that names it (for errors).
    File { key: String, path: PathBuf },
    /// Data compiled into the binary and read by name (a bundled mesh): `name` labels it.
    Embedded {
        key: String,
        name: String,
        bytes: &'static [u8],
    },
}

/// An input with its content hash.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Hashed {
    /// The path as the run opens it, or `bundled:<name>`.
    pub label: String,
    /// 32 hex digits of BLAKE3 of the bytes.
    pub hash: String,
}

type FileKey = (PathBuf, u64, Option<std::time::SystemTime>);

static FILES: Mutex<Option<HashMap<FileKey, String>>> = Mutex::new(None);
static EMBEDDED: Mutex<Option<HashMap<(usize, usize), String>>> = Mutex::new(None);

/// How many times this process read a file (or embedded data) to hash it: the cache's misses
/// (`shscale bench runner` reports them).
pub(crate) static HASHED_READS: std::sync::atomic::AtomicUsize =
    std::sync::atomic::AtomicUsize::new(0);

fn hex(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex()[..32].to_string()
}

/// The content hash of the regular file at `path`, from the cache while its size and
/// modification time are unchanged. An error names the file (absent, not a regular file).
pub(crate) fn hash_file(path: &Path) -> Result<String, Error> {
    if !shscale_files::input::regular_file(path)? {
        return Err(Error::io(path, "no such file"));
    }
    let m = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    let key = (path.to_path_buf(), m.len(), m.modified().ok());
    // The lock is held through a miss's read: runs resolved in parallel wait for the first
    // one's hash instead of reading the file again.
    let mut c = FILES.lock().unwrap_or_else(|e| e.into_inner());
    let c = c.get_or_insert_with(HashMap::new);
    if let Some(h) = c.get(&key) {
        return Ok(h.clone());
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    HASHED_READS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let h = hex(&bytes);
    c.insert(key, h.clone());
    Ok(h)
}

/// The content hash of embedded data, once per process.
pub(crate) fn hash_embedded(bytes: &'static [u8]) -> String {
    let key = (bytes.as_ptr() as usize, bytes.len());
    let mut c = EMBEDDED.lock().unwrap_or_else(|e| e.into_inner());
    let c = c.get_or_insert_with(HashMap::new);
    if let Some(h) = c.get(&key) {
        return h.clone();
    }
    HASHED_READS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let h = hex(bytes);
    c.insert(key, h.clone());
    h
}

/// Every input hashed, sorted by label and deduplicated; an error is `(key, message)`, the
/// parameter naming the file that could not be read.
pub(crate) fn hash_all(inputs: &[Input]) -> Result<Vec<Hashed>, (String, String)> {
    let mut out = Vec::with_capacity(inputs.len());
    for i in inputs {
        out.push(match i {
            Input::File { key, path } => Hashed {
                label: path.display().to_string(),
                hash: hash_file(path).map_err(|e| (key.clone(), e.to_string()))?,
            },
            Input::Embedded { name, bytes, .. } => Hashed {
                label: format!("bundled:{name}"),
                hash: hash_embedded(bytes),
            },
        });
    }
    out.sort();
    out.dedup();
    Ok(out)
}

/// The `inputs` cell of a run's rows: `none` without inputs, else 16 hex digits of BLAKE3 over
/// the sorted `label\thash` lines — equal exactly when every input has the same label and
/// content.
pub fn digest(hashed: &[Hashed]) -> String {
    if hashed.is_empty() {
        return "none".into();
    }
    let mut h = blake3::Hasher::new();
    for x in hashed {
        h.update(x.label.as_bytes());
        h.update(b"\t");
        h.update(x.hash.as_bytes());
        h.update(b"\n");
    }
    h.finalize().to_hex()[..16].to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_is_hashed_once_until_it_changes_and_the_digest_follows_its_content() {
        let d = std::env::temp_dir().join(format!("shscale-inputs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let f = d.join("torus.obj");
        std::fs::write(&f, "v 0 0 0\n").unwrap();
        let key = "mesh".to_string();
        let one = [Input::File {
            key: key.clone(),
            path: f.clone(),
        }];
        let before = HASHED_READS.load(std::sync::atomic::Ordering::Relaxed);
        let a = hash_all(&one).unwrap();
        for _ in 0..100 {
            assert_eq!(hash_all(&one).unwrap(), a);
        }
        let reads = HASHED_READS.load(std::sync::atomic::Ordering::Relaxed) - before;
        // Other tests hash in parallel: at most a few reads, not 101.
        assert!(reads <= 3, "{reads} reads for 101 hashes of one file");
        // Other content (and another length): another hash and digest.
        std::fs::write(&f, "v 0 0 0\nv 1 0 0\n").unwrap();
        let b = hash_all(&one).unwrap();
        assert_ne!(a[0].hash, b[0].hash);
        assert_ne!(digest(&a), digest(&b));
        // The BLAKE3 test vector of the empty input (its first 32 hex digits).
        std::fs::write(&f, "").unwrap();
        let e = hash_all(&one).unwrap();
        assert_eq!(e[0].hash, "af1349b9f5f9a1a6a0404dea36dcc949");
        assert_eq!(digest(&[]), "none");
        let missing = hash_all(&[Input::File {
            key,
            path: d.join("absent.obj"),
        }])
        .unwrap_err();
        assert_eq!(missing.0, "mesh");
        assert!(missing.1.contains("absent.obj"), "{}", missing.1);
        std::fs::remove_dir_all(&d).ok();
    }
}
