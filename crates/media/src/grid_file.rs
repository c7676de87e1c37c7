//! The raw grid file, `blurlab-grid/1`: what a user brings when a medium comes from outside
//! blurlab (documented in docs/formats.md, "Density grids").
//!
//! Little-endian throughout: the 8 bytes `BLGRID01`, three `u32` dimensions `nx ny nz`,
//! then `nx * ny * nz` `f32` densities, x fastest, then nothing. A file that is not exactly
//! that is refused with the file and the byte offset (a wrong magic, a truncated header or
//! body, bytes after the last voxel), and a value that is not a finite density >= 0 with its
//! voxel's index and offset. One file holds one frame; a sequence is numbered files.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::grid::{DensityGrid, GridError, value_error, voxel_count};

/// The file's first 8 bytes.
pub const MAGIC: &[u8; 8] = b"BLGRID01";
/// Header size in bytes: magic and three dimensions.
pub const HEADER_BYTES: usize = 20;

/// Errors of reading or writing a grid file; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum GridFileError {
    /// The file cannot be read or written.
    #[error("grid file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is not a `blurlab-grid/1` file or is cut short or too long.
    #[error("grid file {path}: at byte {offset}: {what}")]
    Format {
        /// The file.
        path: PathBuf,
        /// Where the problem is.
        offset: usize,
        /// What was expected.
        what: String,
    },
    /// The header's dimensions or a voxel's value are refused.
    #[error("grid file {path}: {source}{}", offset.map_or(String::new(), |o| format!(" (byte {o})")))]
    Grid {
        /// The file.
        path: PathBuf,
        /// The voxel's byte offset, for a bad value.
        offset: Option<usize>,
        /// What the grid refused.
        source: GridError,
    },
}

/// Encodes a grid as a `blurlab-grid/1` file's bytes.
pub fn encode(grid: &DensityGrid) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(HEADER_BYTES + 4 * grid.data().len());
    bytes.extend_from_slice(MAGIC);
    for d in grid.dims() {
        // dimensions are at most MAX_DIMENSION, so they fit
        bytes.extend_from_slice(&(d as u32).to_le_bytes());
    }
    for v in grid.data() {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes
}

/// Decodes a `blurlab-grid/1` file's bytes; `path` only names the file in errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<DensityGrid, GridFileError> {
    let format = |offset: usize, what: String| GridFileError::Format { path: path.to_path_buf(), offset, what };
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(format(0, "expected the magic bytes BLGRID01 (a blurlab-grid/1 file)".into()));
    }
    if bytes.len() < HEADER_BYTES {
        return Err(format(bytes.len(), format!("header cut short: expected {HEADER_BYTES} bytes")));
    }
    let word = |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]) as usize;
    let dims = [word(8), word(12), word(16)];
    let count = voxel_count(dims).map_err(|source| GridFileError::Grid {
        path: path.to_path_buf(),
        offset: Some(8),
        source,
    })?;
    let expected = HEADER_BYTES + 4 * count;
    if bytes.len() < expected {
        return Err(format(
            bytes.len(),
            format!(
                "truncated: {}x{}x{} voxels need {expected} bytes, the file ends after {}",
                dims[0],
                dims[1],
                dims[2],
                bytes.len()
            ),
        ));
    }
    if bytes.len() > expected {
        return Err(format(expected, format!("{} bytes after the last voxel", bytes.len() - expected)));
    }
    let data: Vec<f32> =
        bytes[HEADER_BYTES..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    if let Some(index) = data.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
        return Err(GridFileError::Grid {
            path: path.to_path_buf(),
            offset: Some(HEADER_BYTES + 4 * index),
            source: value_error(dims, index, data[index]),
        });
    }
    DensityGrid::new(dims, data).map_err(|source| GridFileError::Grid {
        path: path.to_path_buf(),
        offset: None,
        source,
    })
}

/// Reads a grid file.
pub fn read(path: &Path) -> Result<DensityGrid, GridFileError> {
    let bytes = std::fs::read(path).map_err(|source| GridFileError::Io { path: path.to_path_buf(), source })?;
    decode(&bytes, path)
}

/// Writes a grid file atomically: a temporary file beside it, then a rename.
pub fn write(grid: &DensityGrid, path: &Path) -> Result<(), GridFileError> {
    let io = |source| GridFileError::Io { path: path.to_path_buf(), source };
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(&encode(grid)).map_err(io)?;
    f.sync_all().map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> DensityGrid {
        DensityGrid::new([3, 2, 2], (0..12).map(|v| v as f32 * 0.5).collect()).unwrap()
    }

    #[test]
    fn round_trip_through_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("smoke-0001.blgrid");
        write(&grid(), &p).unwrap();
        assert_eq!(read(&p).unwrap(), grid());
        assert_eq!(std::fs::metadata(&p).unwrap().len() as usize, HEADER_BYTES + 48);
    }

    #[test]
    fn malformed_files_are_refused_with_the_offset() {
        let p = Path::new("cloud.blgrid");
        let good = encode(&grid());
        let msg = |b: &[u8]| decode(b, p).unwrap_err().to_string();
        assert!(msg(b"VDB\0whatever").contains("at byte 0: expected the magic"));
        assert!(msg(&good[..14]).contains("header cut short"));
        let m = msg(&good[..good.len() - 3]);
        assert!(m.contains("cloud.blgrid") && m.contains("truncated") && m.contains("68 bytes"), "{m}");
        let mut long = good.clone();
        long.extend_from_slice(&[0, 0]);
        assert!(msg(&long).contains("at byte 68: 2 bytes after the last voxel"));
        let mut zero = good.clone();
        zero[12..16].copy_from_slice(&0u32.to_le_bytes());
        assert!(msg(&zero).contains("grid dimensions 3x0x2"));
        let mut nan = good;
        let at = HEADER_BYTES + 4 * 7;
        nan[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let m = msg(&nan);
        assert!(m.contains("voxel (1, 0, 1) (index 7)") && m.contains("(byte 48)"), "{m}");
    }

    #[test]
    fn a_missing_file_names_itself() {
        let e = read(Path::new("/nonexistent/smoke.blgrid")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/smoke.blgrid"), "{e}");
    }
}
