//! Writing a file so that it is either the old file or the complete new one, never half-written:
//! write a sibling temporary file, flush it to disk, then rename it over the target.

use std::fs::File;
use std::io::{self, BufWriter};
use std::path::Path;

/// Calls `write` on a buffered temporary file next to `path`, then renames it into place. On any
/// error the temporary file is removed and `path` is left as it was.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    let tmp = path.with_file_name(name);
    let result = (|| {
        let mut out = BufWriter::new(File::create(&tmp)?);
        write(&mut out)?;
        out.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
