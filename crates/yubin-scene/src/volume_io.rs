//! Reading Mitsuba's binary `.vol` grids (the format of its `gridvolume`):
//!
//! | bytes | content |
//! |---|---|
//! | 0–2 | `VOL` |
//! | 3 | version, 3 |
//! | 4–7 | encoding (i32, little-endian): 1 = dense float32 |
//! | 8–19 | resolution x, y, z (3 × i32) |
//! | 20–23 | channels (i32): 1 or 3 |
//! | 24–47 | bounding box: min x, y, z, max x, y, z (6 × f32) |
//! | 48– | x · y · z · channels f32 values, x fastest, then y, then z, channels interleaved |
//!
//! Every check fails with a message that says what is wrong: a file too
//! short for its header or its data (truncated), another magic number,
//! version or encoding, impossible resolutions or channel counts, and
//! non-finite values. Values may be negative (an `sdfgrid`'s distances);
//! `gridvolume` refuses negative densities when it takes the grid.

use glam::Vec3;
use std::path::Path;
use yubin_core::math::Bounds3;
use yubin_core::medium::Grid;

const HEADER: usize = 48;

/// The grid in the `.vol` file at `path`.
pub fn read_vol(path: &Path) -> Result<Grid, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    parse_vol(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// The grid held by the bytes of a `.vol` file.
pub fn parse_vol(bytes: &[u8]) -> Result<Grid, String> {
    if bytes.len() < HEADER {
        return Err(format!(
            "{} bytes: too short for a .vol header (48 bytes); truncated?",
            bytes.len()
        ));
    }
    if &bytes[0..3] != b"VOL" {
        return Err("not a Mitsuba .vol file (it does not start with \"VOL\")".into());
    }
    if bytes[3] != 3 {
        return Err(format!(
            ".vol version {} (only version 3 is defined)",
            bytes[3]
        ));
    }
    let int = |at: usize| i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    let encoding = int(4);
    if encoding != 1 {
        return Err(format!(
            "encoding {encoding}: only dense float32 grids (encoding 1) are supported"
        ));
    }
    let dims = [int(8), int(12), int(16)];
    if dims.iter().any(|&d| d <= 0) {
        return Err(format!(
            "resolution {dims:?}: every side must be at least 1"
        ));
    }
    let channels = int(20);
    if ![1, 3, 6].contains(&channels) {
        return Err(format!(
            "{channels} channels: a volume has 1 or 3 (6 for an sggx phase function's S)"
        ));
    }
    let min = Vec3::new(float(24), float(28), float(32));
    let max = Vec3::new(float(36), float(40), float(44));
    if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
        return Err(format!(
            "bounding box {min} to {max} is empty or not finite"
        ));
    }
    let count = dims
        .iter()
        .try_fold(channels as u64, |acc, &d| acc.checked_mul(d as u64))
        .filter(|&n| n <= (usize::MAX / 4) as u64)
        .ok_or_else(|| format!("resolution {dims:?} is too large"))?;
    yubin_core::limits::Limit::GridCells.check(count, || {
        format!("the grid of {dims:?} × {channels} channels = {count} values")
    })?;
    let count = count as usize;
    let data_bytes = &bytes[HEADER..];
    if data_bytes.len() != count * 4 {
        return Err(format!(
            "{dims:?} × {channels} channels needs {} bytes of data, the file has {} (truncated?)",
            count * 4,
            data_bytes.len()
        ));
    }
    let data = data_bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    Grid::new_signed(
        dims.map(|d| d as u32),
        channels as u32,
        Bounds3 { min, max },
        data,
    )
    .map_err(|e| e.to_string())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The bytes of a `.vol` file.
    pub(crate) fn vol_bytes(dims: [i32; 3], channels: i32, data: &[f32]) -> Vec<u8> {
        let mut b = b"VOL".to_vec();
        b.push(3);
        for v in [1, dims[0], dims[1], dims[2], channels] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in [-1.0f32, -1.0, -1.0, 1.0, 1.0, 1.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in data {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    #[test]
    fn reads_a_grid() {
        let g = parse_vol(&vol_bytes([2, 1, 1], 1, &[0.5, 1.5])).unwrap();
        assert_eq!((g.res, g.channels), ([2, 1, 1], 1));
        assert_eq!(g.bounds.min, Vec3::splat(-1.0));
        assert_eq!(g.eval(Vec3::ZERO).x, 1.0);
        let rgb = parse_vol(&vol_bytes([1, 1, 1], 3, &[0.1, 0.2, 0.3])).unwrap();
        assert_eq!(rgb.eval(Vec3::ZERO), Vec3::new(0.1, 0.2, 0.3));
    }

    #[test]
    fn bad_files_say_what_is_wrong() {
        let good = vol_bytes([2, 2, 2], 1, &[1.0; 8]);
        let mut wrong_version = good.clone();
        wrong_version[3] = 2;
        let mut wrong_magic = good.clone();
        wrong_magic[0] = b'X';
        let mut wrong_encoding = good.clone();
        wrong_encoding[4] = 2;
        for (bytes, says) in [
            (good[..good.len() - 4].to_vec(), "truncated"),
            (good[..20].to_vec(), "truncated"),
            (wrong_version, "version 2"),
            (wrong_magic, "not a Mitsuba .vol"),
            (wrong_encoding, "encoding 2"),
            (vol_bytes([2, 0, 2], 1, &[]), "resolution"),
            (vol_bytes([1, 1, 1], 2, &[1.0, 1.0]), "2 channels"),
            (
                vol_bytes([2, 1, 1], 1, &[1.0, f32::NAN]),
                "voxel [1, 0, 0] holds NaN",
            ),
        ] {
            let e = parse_vol(&bytes).unwrap_err();
            assert!(e.contains(says), "{e}");
        }
        // Negative values are read (signed distances); a density grid
        // refuses them when it takes the grid.
        let signed = parse_vol(&vol_bytes([2, 1, 1], 1, &[1.0, -0.5])).unwrap();
        let e = signed.check_non_negative().unwrap_err().to_string();
        assert!(e.contains("voxel [1, 0, 0] holds -0.5"), "{e}");
    }
}
