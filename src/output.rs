//! Files a user opens with numpy or any JSON reader: `.npy` arrays (little-endian,
//! C order, via `npyz`) and pretty-printed JSON. Each file is written under a temporary
//! name and renamed into place, so a file that exists is complete.

use crate::error::{Error, Result};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes through a temporary file beside `path`, renamed into place once complete.
fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    let tmp: PathBuf = {
        let mut name = path.file_name().unwrap_or_default().to_os_string();
        name.push(".partial");
        path.with_file_name(name)
    };
    let file = std::fs::File::create(&tmp).map_err(io_err(&tmp))?;
    let mut w = BufWriter::new(file);
    body(&mut w).and_then(|_| w.flush()).map_err(io_err(path))?;
    drop(w);
    std::fs::rename(&tmp, path).map_err(io_err(path))
}

/// Writes an n-dimensional array (C order) as `.npy`. `data.len()` must equal the
/// product of `shape`.
pub fn write_npy<T>(path: &Path, shape: &[usize], data: &[T]) -> Result<()>
where
    T: npyz::AutoSerialize + npyz::Serialize + Copy,
{
    use npyz::WriterBuilder;
    let count: usize = shape.iter().product();
    assert_eq!(
        count,
        data.len(),
        "npy shape does not match the data length"
    );
    let shape: Vec<u64> = shape.iter().map(|&s| s as u64).collect();
    write_atomically(path, |w| {
        let mut npy = npyz::WriteOptions::<T>::new()
            .default_dtype()
            .shape(&shape)
            .writer(w)
            .begin_nd()?;
        npy.extend(data.iter().copied())?;
        npy.finish()
    })
}

/// Writes a value as pretty-printed JSON.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value).map_err(std::io::Error::other)?;
        w.write_all(b"\n")
    })
}

/// Creates the output directory (and parents).
pub fn ensure_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(io_err(dir))
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
        assert!(!dir.path().join("a.npy.partial").exists());
    }
}
