//! Atomic file output: every file scene-gen writes appears whole or not at all.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// An output file could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {source}", path.display())]
pub struct WriteError {
    pub path: PathBuf,
    #[source]
    pub source: std::io::Error,
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a
/// reader never sees a partial file and a failure leaves nothing behind.
///
/// The temporary name is unique across threads, processes and machines (host, process id,
/// time and a per-process counter): shard runs of `scene-gen dataset` on different machines
/// write the same shared files into one folder, and every container's first process is pid 1.
/// Writers of one path write the same bytes, so whichever rename lands last, the file is whole.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let err = |source| WriteError { path: path.to_path_buf(), source };
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp{:016x}", unique_token()));
    let result = (|| {
        let mut file = std::fs::File::create(&tmp)?;
        file.write_all(bytes)?;
        // No fsync: outputs are regenerable from their seed, and the rename alone already
        // guarantees readers never see a partial file; an fsync per file would dominate the
        // time to write a scene.
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(err)
}

/// A token no other writer of the same folder draws: a hash of host, pid, time and a counter.
fn unique_token() -> u64 {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
    let host = std::env::var("HOSTNAME").unwrap_or_default();
    let count = COUNTER.fetch_add(1, Ordering::Relaxed);
    crate::rng::fnv1a64(format!("{host}/{}/{nanos}/{count}", std::process::id()).as_bytes())
}
