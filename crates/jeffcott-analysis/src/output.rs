//! Files a user opens with numpy or any JSON reader: `.npy` arrays (little-endian,
//! C order, via `npyz`), pretty-printed JSON and PNG. Each file is written under a
//! unique temporary name in the same directory, synced and renamed into place, so a file
//! that exists under its final name is complete.

use jeffcott_core::error::{Error, Result};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Held while a file is being written and renamed into place. A signal handler that
/// takes it before exiting (the CLI's) can never leave a temporary file behind or cut a
/// rename short; library code holds it only for one file at a time.
pub fn commit_lock() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock().unwrap_or_else(|p| p.into_inner())
}

/// A temporary name beside `path`, unique to this process and call: two runs (or two
/// threads) writing the same file never share a temporary. Hidden (leading dot) and
/// ending in `.tmp`, so [`remove_temporaries`] can find what a killed process left.
pub fn temporary_name(path: &Path) -> PathBuf {
    static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let seq = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let mut name = std::ffi::OsString::from(".");
    name.push(path.file_name().unwrap_or_default());
    name.push(format!(".{}-{seq}.tmp", std::process::id()));
    path.with_file_name(name)
}

/// Removes the temporaries ([`temporary_name`]) that a killed process left in `dir`.
/// Call only while holding the directory's run lock (no live writer then).
pub fn remove_temporaries(dir: &Path) -> Result<usize> {
    let mut removed = 0;
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(io_err(dir)(e)),
    };
    for entry in entries {
        let entry = entry.map_err(io_err(dir))?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if name.starts_with('.') && name.ends_with(".tmp") {
            std::fs::remove_file(entry.path()).map_err(io_err(&entry.path()))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Flushes a directory's entries (the renames in it) to disk; best effort, since some
/// file systems refuse to open a directory for syncing.
pub fn sync_dir(dir: &Path) {
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Writes through a unique temporary file beside `path`, synced and renamed into place
/// once complete, so a file under its final name is always whole. On any error (disk
/// full included) the temporary is removed and the error names `path`.
pub fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    let _guard = commit_lock();
    let tmp = temporary_name(path);
    let result = (|| -> std::io::Result<()> {
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        let mut w = BufWriter::new(file);
        body(&mut w)?;
        w.flush()?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)
    })();
    match result {
        Ok(()) => {
            if let Some(dir) = path.parent() {
                sync_dir(dir);
            }
            Ok(())
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(io_err(path)(e))
        }
    }
}

/// Writes an 8-bit RGB image (`rgb`: width x height x 3 bytes, row-major) as PNG.
pub fn write_png(path: &Path, (width, height): (u32, u32), rgb: &[u8]) -> Result<()> {
    write_atomically(path, |w| {
        let mut enc = png::Encoder::new(w, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let to_io = |e: png::EncodingError| match e {
            png::EncodingError::IoError(e) => e,
            e => std::io::Error::other(e),
        };
        let mut writer = enc.write_header().map_err(to_io)?;
        writer.write_image_data(rgb).map_err(to_io)?;
        writer.finish().map_err(to_io)
    })
}

/// Writes an n-dimensional array (C order) as `.npy`. `data.len()` must equal the
/// product of `shape`.
pub fn write_npy<T>(path: &Path, shape: &[usize], data: &[T]) -> Result<()>
where
    T: npyz::AutoSerialize + npyz::Serialize + Copy,
{
    let count: usize = shape.iter().product();
    assert_eq!(
        count,
        data.len(),
        "npy shape does not match the data length"
    );
    write_npy_with(path, shape, |npy| npy.extend(data.iter().copied()))
}

/// Writes an n-dimensional array (C order) as `.npy` from consecutive parts (e.g. one
/// per work unit), so the whole array is never in memory. The parts must add up to the
/// product of `shape`; a part that fails to load aborts the write (no file is left).
pub fn write_npy_parts<T, I>(path: &Path, shape: &[usize], parts: I) -> Result<()>
where
    T: npyz::AutoSerialize + npyz::Serialize + Copy,
    I: Iterator<Item = Result<Vec<T>>>,
{
    let count: usize = shape.iter().product();
    write_npy_with(path, shape, |npy| {
        let mut n = 0usize;
        for part in parts {
            let part = part.map_err(std::io::Error::other)?;
            n += part.len();
            npy.extend(part.iter().copied())?;
        }
        if n != count {
            return Err(std::io::Error::other(format!(
                "{n} values for a shape of {count}"
            )));
        }
        Ok(())
    })
}

/// The writer of a `.npy` array of `shape` (C order, the element type's default dtype):
/// writes the header, lets `body` push the elements, then finishes the file, all inside
/// one atomic write (nothing is left behind when `body` fails).
fn write_npy_with<T>(
    path: &Path,
    shape: &[usize],
    body: impl FnOnce(&mut npyz::NpyWriter<T, &mut BufWriter<std::fs::File>>) -> std::io::Result<()>,
) -> Result<()>
where
    T: npyz::AutoSerialize + npyz::Serialize + Copy,
{
    use npyz::WriterBuilder;
    let dims: Vec<u64> = shape.iter().map(|&s| s as u64).collect();
    write_atomically(path, |w| {
        let mut npy = npyz::WriteOptions::<T>::new()
            .default_dtype()
            .shape(&dims)
            .writer(w)
            .begin_nd()?;
        body(&mut npy)?;
        npy.finish()
    })
}

/// Reads an f64 `.npy` file (C order, as every file jeffcott writes) as its shape and
/// values; errors name `option` and the file (missing, unreadable, another type or
/// Fortran order).
pub fn read_npy_f64(option: &str, path: &Path) -> Result<(Vec<u64>, Vec<f64>)> {
    let bad = |why: String| Error::invalid(option, path.display(), why);
    let bytes = std::fs::read(path).map_err(|e| bad(format!("cannot read it: {e}")))?;
    let npy = npyz::NpyFile::new(&bytes[..]).map_err(|e| bad(format!("not a .npy file: {e}")))?;
    if npy.order() == npyz::Order::Fortran {
        return Err(bad("a Fortran-ordered array; save it in C order".into()));
    }
    let shape = npy.shape().to_vec();
    let data = npy
        .into_vec::<f64>()
        .map_err(|e| bad(format!("not an f64 array: {e}")))?;
    Ok((shape, data))
}

/// Writes a value as pretty-printed JSON with the keys of every object sorted: the value
/// goes through [`serde_json::Value`], whose map is ordered by key, so a file is the
/// same whatever order a record's struct declares its fields in (and equal to what the
/// earlier `json!`-built files held).
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let value = serde_json::to_value(value).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })?;
    write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, &value).map_err(std::io::Error::other)?;
        w.write_all(b"\n")
    })
}

/// Creates the output directory (and parents); an existing non-directory is an error
/// naming it.
pub fn ensure_dir(dir: &Path) -> Result<()> {
    // A symbolic link that leads nowhere (dangling, or a loop) is not a directory to
    // create: say so rather than the operating system's "File exists".
    if let Ok(meta) = std::fs::symlink_metadata(dir)
        && meta.file_type().is_symlink()
        && let Err(e) = std::fs::metadata(dir)
    {
        let why = match std::fs::read_link(dir) {
            Ok(to) if e.raw_os_error() == Some(40) => {
                format!("is a symbolic link to {} that loops", to.display())
            }
            Ok(to) => format!(
                "is a symbolic link to {}, which does not exist; create it or choose another directory",
                to.display()
            ),
            Err(_) => "is a symbolic link that cannot be followed".to_string(),
        };
        return Err(Error::Io {
            path: dir.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, why),
        });
    }
    if dir.exists() && !dir.is_dir() {
        return Err(Error::Io {
            path: dir.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::AlreadyExists,
                "exists and is not a directory",
            ),
        });
    }
    std::fs::create_dir_all(dir).map_err(io_err(dir))
}

/// Writes a CSV table (header, then one line per row, numbers in Rust's shortest
/// round-trip form) through a temporary renamed into place, as every other file.
pub fn write_csv(path: &Path, header: &[&str], rows: impl Iterator<Item = Vec<f64>>) -> Result<()> {
    write_atomically(path, |w| {
        writeln!(w, "{}", header.join(","))?;
        for r in rows {
            let line: Vec<String> = r.iter().map(|v| v.to_string()).collect();
            writeln!(w, "{}", line.join(","))?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The NPY v1.0 header as the format spec defines it: magic, version, header length,
    /// a dict with descr '<f8', fortran_order False and the shape, padded to 64 bytes.
    #[test]
    fn npy_files_follow_the_format_spec() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.npy");
        let data: Vec<f64> = (0..6).map(|i| i as f64 * 0.5).collect();
        write_npy(&path, &[2, 3], &data).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..6], b"\x93NUMPY");
        let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!(
            (10 + hlen) % 64,
            0,
            "header must pad the data start to 64 bytes"
        );
        let header = std::str::from_utf8(&bytes[10..10 + hlen]).unwrap();
        assert!(header.contains("'descr': '<f8'"), "{header}");
        assert!(header.contains("'fortran_order': False"), "{header}");
        // A Python tuple literal; a trailing comma is legal ("(2, 3, )").
        let compact: String = header.chars().filter(|c| !c.is_whitespace()).collect();
        assert!(
            compact.contains("'shape':(2,3)") || compact.contains("'shape':(2,3,)"),
            "{header}"
        );
        let body = &bytes[10 + hlen..];
        assert_eq!(body.len(), 48);
        assert_eq!(f64::from_le_bytes(body[40..48].try_into().unwrap()), 2.5);
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(left.len(), 1, "no temporary may remain beside a.npy");
    }
}
