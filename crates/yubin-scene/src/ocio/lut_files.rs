//! LUT files of OCIO's FileTransform, each read into processor operations
//! (domain fits as matrices, then the table):
//!
//! - `.spi1d` (Sony Pictures Imageworks): `Version 1`, `From MIN MAX`,
//!   `Length N`, `Components 1|3`, then the values between `{` and `}`.
//! - `.spi3d`: `SPILUT 1.0`, `3 3`, `N N N`, then lines `i j k r g b`.
//! - `.spimtx`: three rows of four numbers, a 3×3 matrix and an offset in
//!   16-bit code values (divided by 65535).
//! - `.cube` (IRIDAS/Resolve): `LUT_1D_SIZE` and/or `LUT_3D_SIZE`,
//!   `DOMAIN_MIN`/`DOMAIN_MAX` or `LUT_1D_INPUT_RANGE`/
//!   `LUT_3D_INPUT_RANGE`, red varying fastest.

use super::ops::{Lut1d, Lut3d, Op};
use crate::error::{Location, SceneError};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How a 3D LUT is interpolated (1D LUTs are always linear).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Interpolation {
    Linear,
    Tetrahedral,
}

/// The operations of the LUT file at `path`.
pub fn read_lut(path: &Path, interp: Interpolation) -> Result<Vec<Op>, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|error| SceneError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let file = Arc::new(path.to_path_buf());
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    match ext.as_str() {
        "spi1d" => read_spi1d(&text, &file),
        "spi3d" => read_spi3d(&text, &file, interp),
        "spimtx" => read_spimtx(&text, &file),
        "cube" => read_cube(&text, &file, interp),
        _ => Err(SceneError::file(
            path,
            format!(
                "unsupported LUT format \".{ext}\" (supported: .spi1d, .spi3d, .spimtx, .cube)"
            ),
        )),
    }
}

fn bad(file: &Arc<PathBuf>, line: usize, msg: impl Into<String>) -> SceneError {
    SceneError::at(&Location::new(file.clone(), line as u32), msg)
}

fn numbers(words: &[&str], file: &Arc<PathBuf>, line: usize) -> Result<Vec<f64>, SceneError> {
    words
        .iter()
        .map(|w| {
            w.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(file, line, format!("expected a number, found \"{w}\"")))
        })
        .collect()
}

/// Lines as (1-based number, words), blank lines and `#` comments dropped.
fn lines(text: &str) -> impl Iterator<Item = (usize, Vec<&str>)> {
    text.lines().enumerate().filter_map(|(i, l)| {
        let l = l.split('#').next().unwrap_or("").trim();
        (!l.is_empty()).then(|| (i + 1, l.split_whitespace().collect()))
    })
}

fn domain_fit(min: [f64; 3], max: [f64; 3]) -> Option<Op> {
    (min != [0.0; 3] || max != [1.0; 3]).then(|| Op::fit(min, max, [0.0; 3], [1.0; 3]))
}

fn check_domain(
    min: [f64; 3],
    max: [f64; 3],
    file: &Arc<PathBuf>,
    line: usize,
) -> Result<(), SceneError> {
    if (0..3).any(|i| max[i] <= min[i]) {
        return Err(bad(
            file,
            line,
            "the LUT's domain is empty (maximum not above minimum)",
        ));
    }
    Ok(())
}

fn read_spi1d(text: &str, file: &Arc<PathBuf>) -> Result<Vec<Op>, SceneError> {
    let (mut from, mut length, mut components) = ([0.0, 1.0], None, 1usize);
    let mut values: Vec<f64> = Vec::new();
    let mut in_table = false;
    let mut last_line = 0;
    for (n, words) in lines(text) {
        last_line = n;
        if in_table {
            if words[0] == "}" {
                in_table = false;
                continue;
            }
            values.extend(numbers(&words, file, n)?);
            continue;
        }
        match words[0] {
            "Version" => {}
            "From" if words.len() == 3 => {
                let v = numbers(&words[1..], file, n)?;
                from = [v[0], v[1]];
                check_domain([from[0]; 3], [from[1]; 3], file, n)?;
            }
            "Length" if words.len() == 2 => {
                length = Some(
                    words[1]
                        .parse::<usize>()
                        .map_err(|_| bad(file, n, "Length must be a whole number"))?,
                );
            }
            "Components" if words.len() == 2 => {
                components = match words[1] {
                    "1" => 1,
                    "3" => 3,
                    c => return Err(bad(file, n, format!("Components must be 1 or 3, not {c}"))),
                };
            }
            "{" => in_table = true,
            w => {
                return Err(bad(
                    file,
                    n,
                    format!("unexpected \"{w}\" in a .spi1d header"),
                ))
            }
        }
    }
    let length = length.ok_or_else(|| bad(file, last_line, "no Length in the .spi1d header"))?;
    if length < 2 || values.len() != length * components {
        return Err(bad(
            file,
            last_line,
            format!(
                "expected {length} entries of {components} values, found {} values",
                values.len()
            ),
        ));
    }
    let table = values
        .chunks_exact(components)
        .map(|v| [0, 1, 2].map(|c| v[c.min(components - 1)] as f32))
        .collect();
    let mut ops: Vec<Op> = domain_fit([from[0]; 3], [from[1]; 3]).into_iter().collect();
    ops.push(Op::Lut1d {
        lut: Arc::new(Lut1d { table }),
        inverse: false,
    });
    Ok(ops)
}

fn read_spi3d(
    text: &str,
    file: &Arc<PathBuf>,
    interp: Interpolation,
) -> Result<Vec<Op>, SceneError> {
    let mut it = lines(text);
    let header = it.next();
    if !matches!(&header, Some((_, w)) if w.first() == Some(&"SPILUT")) {
        return Err(bad(file, 1, "not a .spi3d file (no SPILUT header)"));
    }
    let _dims = it.next();
    let (n, size_words) = it.next().ok_or_else(|| bad(file, 1, "no LUT size"))?;
    let sizes = numbers(&size_words, file, n)?;
    if sizes.len() != 3
        || sizes[0] != sizes[1]
        || sizes[1] != sizes[2]
        || sizes[0] < 2.0
        || sizes[0] > 256.0
    {
        return Err(bad(file, n, "expected three equal sizes between 2 and 256"));
    }
    let size = sizes[0] as usize;
    let mut table = vec![[f32::NAN; 3]; size * size * size];
    for (n, words) in it {
        let v = numbers(&words, file, n)?;
        if v.len() != 6 {
            return Err(bad(file, n, "expected \"i j k r g b\""));
        }
        let idx = [v[0], v[1], v[2]];
        if idx
            .iter()
            .any(|&i| i < 0.0 || i >= size as f64 || i.fract() != 0.0)
        {
            return Err(bad(file, n, format!("index outside the {size}³ lattice")));
        }
        let [i, j, k] = idx.map(|i| i as usize);
        table[i + size * (j + size * k)] = [v[3] as f32, v[4] as f32, v[5] as f32];
    }
    if table.iter().any(|v| v[0].is_nan()) {
        return Err(bad(file, 0, "some lattice points have no entry"));
    }
    Ok(vec![Op::Lut3d {
        lut: Arc::new(Lut3d { size, table }),
        tetrahedral: interp == Interpolation::Tetrahedral,
    }])
}

fn read_spimtx(text: &str, file: &Arc<PathBuf>) -> Result<Vec<Op>, SceneError> {
    let mut v = Vec::new();
    let mut last = 1;
    for (n, words) in lines(text) {
        v.extend(numbers(&words, file, n)?);
        last = n;
    }
    if v.len() != 12 {
        return Err(bad(
            file,
            last,
            format!("expected 12 numbers (3 rows of 4), found {}", v.len()),
        ));
    }
    let m = [0, 1, 2].map(|r| [v[4 * r], v[4 * r + 1], v[4 * r + 2]]);
    let offset = [0, 1, 2].map(|r| v[4 * r + 3] / 65535.0);
    Ok(vec![Op::Matrix { m, offset }])
}

fn read_cube(
    text: &str,
    file: &Arc<PathBuf>,
    interp: Interpolation,
) -> Result<Vec<Op>, SceneError> {
    let (mut size1, mut size3) = (None, None);
    let (mut min1, mut max1) = ([0.0; 3], [1.0; 3]);
    let (mut min3, mut max3) = ([0.0; 3], [1.0; 3]);
    let mut rows: Vec<[f32; 3]> = Vec::new();
    let mut last = 1;
    for (n, words) in lines(text) {
        last = n;
        let key = words[0];
        let three = |w: &[&str]| -> Result<[f64; 3], SceneError> {
            let v = numbers(w, file, n)?;
            (v.len() == 3)
                .then(|| [v[0], v[1], v[2]])
                .ok_or_else(|| bad(file, n, format!("{key} takes 3 numbers")))
        };
        let size = || -> Result<usize, SceneError> {
            words
                .get(1)
                .and_then(|w| w.parse::<usize>().ok())
                .filter(|s| *s >= 2)
                .ok_or_else(|| {
                    bad(
                        file,
                        n,
                        format!("{key} must be a whole number of at least 2"),
                    )
                })
        };
        match key {
            "TITLE" => {}
            "LUT_1D_SIZE" => size1 = Some(size()?),
            "LUT_3D_SIZE" => {
                let s = size()?;
                if s > 256 {
                    return Err(bad(file, n, "LUT_3D_SIZE above 256"));
                }
                size3 = Some(s);
            }
            "DOMAIN_MIN" => {
                min1 = three(&words[1..])?;
                min3 = min1;
            }
            "DOMAIN_MAX" => {
                max1 = three(&words[1..])?;
                max3 = max1;
            }
            "LUT_1D_INPUT_RANGE" | "LUT_3D_INPUT_RANGE" => {
                let v = numbers(&words[1..], file, n)?;
                if v.len() != 2 {
                    return Err(bad(file, n, format!("{key} takes 2 numbers")));
                }
                if key == "LUT_1D_INPUT_RANGE" {
                    (min1, max1) = ([v[0]; 3], [v[1]; 3]);
                } else {
                    (min3, max3) = ([v[0]; 3], [v[1]; 3]);
                }
            }
            _ if key
                .starts_with(|c: char| c.is_ascii_digit() || c == '-' || c == '+' || c == '.') =>
            {
                let v = three(&words)?;
                rows.push(v.map(|x| x as f32));
            }
            _ => return Err(bad(file, n, format!("unknown .cube keyword \"{key}\""))),
        }
    }
    check_domain(min1, max1, file, last)?;
    check_domain(min3, max3, file, last)?;
    let want = size1.unwrap_or(0) + size3.map_or(0, |s| s * s * s);
    if want == 0 || rows.len() != want {
        return Err(bad(
            file,
            last,
            format!(
                "expected {want} table rows (LUT_1D_SIZE/LUT_3D_SIZE), found {}",
                rows.len()
            ),
        ));
    }
    let mut ops = Vec::new();
    let mut rest = rows.as_slice();
    if let Some(s) = size1 {
        ops.extend(domain_fit(min1, max1));
        ops.push(Op::Lut1d {
            lut: Arc::new(Lut1d {
                table: rest[..s].to_vec(),
            }),
            inverse: false,
        });
        rest = &rest[s..];
    }
    if let Some(s) = size3 {
        // With a 1D shaper the 3D table's domain is the shaper's output.
        if size1.is_none() {
            ops.extend(domain_fit(min3, max3));
        }
        ops.push(Op::Lut3d {
            lut: Arc::new(Lut3d {
                size: s,
                table: rest.to_vec(),
            }),
            tetrahedral: interp == Interpolation::Tetrahedral,
        });
    }
    Ok(ops)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file() -> Arc<PathBuf> {
        Arc::new(PathBuf::from("test.lut"))
    }

    #[test]
    fn spi1d_with_a_domain_maps_through_its_table() {
        let text = "Version 1\nFrom -1.0 3.0\nLength 3\nComponents 1\n{\n 0.0\n 0.5\n 2.0\n}\n";
        let ops = read_spi1d(text, &file()).unwrap();
        let apply = |x: f32| ops.iter().fold([x; 3], |v, op| op.apply(v))[0];
        assert!((apply(-1.0) - 0.0).abs() < 1e-6);
        assert!((apply(1.0) - 0.5).abs() < 1e-6);
        assert!((apply(2.0) - 1.25).abs() < 1e-6);
        assert!((apply(9.0) - 2.0).abs() < 1e-6, "clamped to the domain");
    }

    #[test]
    fn cube_orders_red_fastest_and_reads_its_domain() {
        let mut text = String::from(
            "TITLE \"t\"\n# comment\nLUT_3D_SIZE 2\nDOMAIN_MIN 0 0 0\nDOMAIN_MAX 2 2 2\n",
        );
        for b in 0..2 {
            for g in 0..2 {
                for r in 0..2 {
                    text += &format!("{} {} {}\n", r as f32 * 0.5, g as f32 * 0.25, b as f32);
                }
            }
        }
        let ops = read_cube(&text, &file(), Interpolation::Tetrahedral).unwrap();
        let out = ops.iter().fold([2.0, 0.0, 1.0], |v, op| op.apply(v));
        assert!(
            (out[0] - 0.5).abs() < 1e-6 && out[1].abs() < 1e-6 && (out[2] - 0.5).abs() < 1e-6,
            "{out:?}"
        );
    }

    #[test]
    fn spimtx_offsets_are_in_16_bit_code_values() {
        let ops = read_spimtx("2 0 0 65535\n0 1 0 0\n0 0 1 0\n", &file()).unwrap();
        let out = ops[0].apply([0.25, 0.5, 0.5]);
        assert!((out[0] - 1.5).abs() < 1e-6 && (out[1] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn spi3d_reads_indexed_entries() {
        let mut text = String::from("SPILUT 1.0\n3 3\n2 2 2\n");
        for i in 0..2 {
            for j in 0..2 {
                for k in 0..2 {
                    text += &format!("{i} {j} {k} {} {} {}\n", k, j, i);
                }
            }
        }
        let ops = read_spi3d(&text, &file(), Interpolation::Linear).unwrap();
        let out = ops[0].apply([1.0, 0.0, 0.25]);
        assert!(
            (out[0] - 0.25).abs() < 1e-6 && out[1].abs() < 1e-6 && (out[2] - 1.0).abs() < 1e-6,
            "{out:?}"
        );
    }

    #[test]
    fn broken_luts_are_named_at_their_line() {
        let e = read_cube(
            "LUT_3D_SIZE 2\n0 0 0\n1 x 0\n",
            &file(),
            Interpolation::Linear,
        )
        .unwrap_err();
        assert!(e.to_string().contains("test.lut:3"), "{e}");
        let e = read_spi1d(
            "Version 1\nFrom 0 1\nLength 4\nComponents 1\n{\n0\n1\n}\n",
            &file(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("expected 4 entries"), "{e}");
        let e = read_spimtx("1 0 0\n", &file()).unwrap_err();
        assert!(e.to_string().contains("12 numbers"), "{e}");
    }
}
