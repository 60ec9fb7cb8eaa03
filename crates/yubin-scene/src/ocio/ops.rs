//! The operations an OCIO processor applies to a pixel, in order: what the
//! config's transforms become once colour spaces, groups, files and
//! directions are resolved. Each has its inverse where OpenColorIO
//! defines one for the transforms Blender's configs use.

use std::sync::Arc;

/// One step of a processor.
#[derive(Clone, Debug)]
pub enum Op {
    /// out = m · in + offset (MatrixTransform, ranges, allocations' fits).
    Matrix { m: [[f64; 3]; 3], offset: [f64; 3] },
    /// log_base(max(x, FLT_MIN)) per channel, or its inverse base^x
    /// (LogTransform, lg2 allocation).
    Log { base: f64, inverse: bool },
    /// max(x, 0)^e per channel (ExponentTransform, negatives clamped).
    Pow { exponent: [f64; 3] },
    /// The monitor curve (ExponentWithLinearTransform): a power law with
    /// a linear segment near black, as the sRGB curve; `encode` is the
    /// inverse direction (linear to encoded). Negatives follow the linear
    /// segment.
    MonCurve {
        gamma: f64,
        offset: f64,
        encode: bool,
    },
    /// Clamps each channel to [min, max] (RangeTransform).
    Clamp { min: f32, max: f32 },
    /// A 1D LUT over [0, 1] (inputs clamped), linearly interpolated, per
    /// channel; `inverse` finds the input giving the value (monotone
    /// tables).
    Lut1d { lut: Arc<Lut1d>, inverse: bool },
    /// A 3D LUT over [0, 1]³ (inputs clamped).
    Lut3d { lut: Arc<Lut3d>, tetrahedral: bool },
    /// The ASC CDL: slope, offset, power (clamped to [0, 1] as its v1.2
    /// style), then saturation around Rec.709 luma.
    Cdl { cdl: Cdl, inverse: bool },
}

/// A 1D table: `n` entries of RGB over the unit interval.
#[derive(Clone, Debug, PartialEq)]
pub struct Lut1d {
    pub table: Vec<[f32; 3]>,
}

/// A 3D table of `size`³ RGB entries, red varying fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct Lut3d {
    pub size: usize,
    pub table: Vec<[f32; 3]>,
}

/// ASC CDL parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cdl {
    pub slope: [f64; 3],
    pub offset: [f64; 3],
    pub power: [f64; 3],
    pub saturation: f64,
}

const REC709_LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];

impl Op {
    /// The matrix that maps [a, b] onto [c, d] in every channel.
    pub fn fit(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> Op {
        let mut m = [[0.0; 3]; 3];
        let mut offset = [0.0; 3];
        for i in 0..3 {
            let scale = (d[i] - c[i]) / (b[i] - a[i]);
            m[i][i] = scale;
            offset[i] = c[i] - a[i] * scale;
        }
        Op::Matrix { m, offset }
    }

    /// The inverse operation, or `None` where it has none here (a 3D LUT,
    /// a clamp, a singular matrix).
    pub fn inverse(&self) -> Option<Op> {
        Some(match self {
            Op::Matrix { m, offset } => {
                let inv = invert3(m)?;
                let offset = mul3(&inv, offset).map(|v| -v);
                Op::Matrix { m: inv, offset }
            }
            Op::Log { base, inverse } => Op::Log {
                base: *base,
                inverse: !inverse,
            },
            Op::Pow { exponent } => Op::Pow {
                exponent: exponent.map(|e| 1.0 / e),
            },
            Op::MonCurve {
                gamma,
                offset,
                encode,
            } => Op::MonCurve {
                gamma: *gamma,
                offset: *offset,
                encode: !encode,
            },
            Op::Lut1d { lut, inverse } => Op::Lut1d {
                lut: lut.clone(),
                inverse: !inverse,
            },
            Op::Cdl { cdl, inverse } => Op::Cdl {
                cdl: *cdl,
                inverse: !inverse,
            },
            Op::Clamp { .. } | Op::Lut3d { .. } => return None,
        })
    }

    /// Applies the operation to one RGB value.
    pub fn apply(&self, rgb: [f32; 3]) -> [f32; 3] {
        match self {
            Op::Matrix { m, offset } => {
                let x = rgb.map(f64::from);
                let y = mul3(m, &x);
                [0, 1, 2].map(|i| (y[i] + offset[i]) as f32)
            }
            Op::Log { base, inverse } => {
                if *inverse {
                    rgb.map(|v| base.powf(f64::from(v)) as f32)
                } else {
                    let ln_base = base.ln();
                    rgb.map(|v| (f64::from(v.max(f32::MIN_POSITIVE)).ln() / ln_base) as f32)
                }
            }
            Op::Pow { exponent } => {
                [0, 1, 2].map(|i| f64::from(rgb[i].max(0.0)).powf(exponent[i]) as f32)
            }
            Op::MonCurve {
                gamma,
                offset,
                encode,
            } => rgb.map(|v| moncurve(f64::from(v), *gamma, *offset, *encode) as f32),
            Op::Clamp { min, max } => rgb.map(|v| v.clamp(*min, *max)),
            Op::Lut1d { lut, inverse } => {
                if *inverse {
                    [0, 1, 2].map(|c| lut.invert(c, rgb[c]))
                } else {
                    [0, 1, 2].map(|c| lut.eval(c, rgb[c]))
                }
            }
            Op::Lut3d { lut, tetrahedral } => {
                if *tetrahedral {
                    lut.tetrahedral(rgb)
                } else {
                    lut.trilinear(rgb)
                }
            }
            Op::Cdl { cdl, inverse } => {
                let x = rgb.map(f64::from);
                let y = if *inverse {
                    cdl.reverse(x)
                } else {
                    cdl.forward(x)
                };
                y.map(|v| v as f32)
            }
        }
    }
}

/// `ops` with every run of consecutive matrices multiplied into one (in
/// f64; OpenColorIO's optimizer does the same): colour space changes
/// through the reference space chain three or four of them.
pub fn fuse_matrices(ops: Vec<Op>) -> Vec<Op> {
    let mut out: Vec<Op> = Vec::with_capacity(ops.len());
    for op in ops {
        if let (Some(Op::Matrix { m: m1, offset: o1 }), Op::Matrix { m: m2, offset: o2 }) =
            (out.last_mut(), &op)
        {
            // (m2 · (m1 x + o1) + o2) = (m2 m1) x + (m2 o1 + o2)
            let m = [0, 1, 2].map(|i| [0, 1, 2].map(|j| (0..3).map(|k| m2[i][k] * m1[k][j]).sum()));
            let o = mul3(m2, o1);
            *o1 = [0, 1, 2].map(|i| o[i] + o2[i]);
            *m1 = m;
            continue;
        }
        out.push(op);
    }
    out
}

/// The monitor curve of gamma `g` and offset `o` (sRGB: 2.4, 0.055):
/// decoding (x + o)/(1 + o))^g above the break point x_b = o/(g − 1),
/// linear below it, the two meeting with equal value and slope; `encode`
/// is its inverse.
fn moncurve(x: f64, g: f64, o: f64, encode: bool) -> f64 {
    let break_encoded = o / (g - 1.0);
    let break_linear = (o * g / ((g - 1.0) * (1.0 + o))).powf(g);
    let slope = break_linear / break_encoded;
    if encode {
        if x >= break_linear {
            (1.0 + o) * x.powf(1.0 / g) - o
        } else {
            x / slope
        }
    } else if x >= break_encoded {
        ((x + o) / (1.0 + o)).powf(g)
    } else {
        x * slope
    }
}

fn mul3(m: &[[f64; 3]; 3], x: &[f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * x[0] + m[i][1] * x[1] + m[i][2] * x[2])
}

fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let cof =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let det = m[0][0] * cof(1, 2, 1, 2) - m[0][1] * cof(1, 2, 0, 2) + m[0][2] * cof(1, 2, 0, 1);
    if det.abs() < 1e-300 || !det.is_finite() {
        return None;
    }
    let inv = [
        [cof(1, 2, 1, 2), -cof(0, 2, 1, 2), cof(0, 1, 1, 2)],
        [-cof(1, 2, 0, 2), cof(0, 2, 0, 2), -cof(0, 1, 0, 2)],
        [cof(1, 2, 0, 1), -cof(0, 2, 0, 1), cof(0, 1, 0, 1)],
    ];
    Some(inv.map(|row| row.map(|v| v / det)))
}

/// A finite value in [0, 1] (NaN → 0).
fn unit(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

impl Lut1d {
    /// The table at `x` (clamped to [0, 1]) in channel `c`.
    pub fn eval(&self, c: usize, x: f32) -> f32 {
        let n = self.table.len();
        if n == 1 {
            return self.table[0][c];
        }
        let t = unit(x) * (n - 1) as f32;
        let i = (t as usize).min(n - 2);
        let f = t - i as f32;
        let (a, b) = (self.table[i][c], self.table[i + 1][c]);
        a + f * (b - a)
    }

    /// The input in [0, 1] at which channel `c` of the (monotone) table
    /// takes the value `y`, interpolating linearly between entries; values
    /// beyond the table's range give its ends. Flat runs give their last
    /// entry when increasing.
    pub fn invert(&self, c: usize, y: f32) -> f32 {
        let n = self.table.len();
        if n < 2 || y.is_nan() {
            return 0.0;
        }
        let first = self.table[0][c];
        let last = self.table[n - 1][c];
        let increasing = last >= first;
        let value = |i: usize| {
            if increasing {
                self.table[i][c]
            } else {
                -self.table[i][c]
            }
        };
        let y = if increasing { y } else { -y };
        if y <= value(0) {
            return 0.0;
        }
        if y >= value(n - 1) {
            return 1.0;
        }
        // First entry above y: y lies in [value(k − 1), value(k)).
        let (mut lo, mut hi) = (0usize, n - 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if value(mid) <= y {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (a, b) = (value(lo), value(hi));
        let f = if b > a { (y - a) / (b - a) } else { 0.0 };
        (lo as f32 + f) / (n - 1) as f32
    }
}

impl Lut3d {
    fn at(&self, r: usize, g: usize, b: usize) -> [f32; 3] {
        self.table[r + self.size * (g + self.size * b)]
    }

    /// Lattice cell and fractions of an input, clamped to the cube.
    fn cell(&self, rgb: [f32; 3]) -> ([usize; 3], [f32; 3]) {
        let max = (self.size - 1) as f32;
        let mut idx = [0usize; 3];
        let mut frac = [0f32; 3];
        for c in 0..3 {
            let t = unit(rgb[c]) * max;
            let i = (t as usize).min(self.size.saturating_sub(2));
            idx[c] = i;
            frac[c] = t - i as f32;
        }
        (idx, frac)
    }

    /// Trilinear interpolation.
    pub fn trilinear(&self, rgb: [f32; 3]) -> [f32; 3] {
        if self.size < 2 {
            return self.table[0];
        }
        let ([r, g, b], [fr, fg, fb]) = self.cell(rgb);
        let lerp = |a: [f32; 3], b: [f32; 3], t: f32| [0, 1, 2].map(|c| a[c] + t * (b[c] - a[c]));
        let c00 = lerp(self.at(r, g, b), self.at(r + 1, g, b), fr);
        let c10 = lerp(self.at(r, g + 1, b), self.at(r + 1, g + 1, b), fr);
        let c01 = lerp(self.at(r, g, b + 1), self.at(r + 1, g, b + 1), fr);
        let c11 = lerp(self.at(r, g + 1, b + 1), self.at(r + 1, g + 1, b + 1), fr);
        lerp(lerp(c00, c10, fg), lerp(c01, c11, fg), fb)
    }

    /// Tetrahedral interpolation (Kasson, Nin, Plouffe and Hafner 1995):
    /// the cube cell split into six tetrahedra along its main diagonal,
    /// the one holding the point chosen by the order of its fractions.
    pub fn tetrahedral(&self, rgb: [f32; 3]) -> [f32; 3] {
        if self.size < 2 {
            return self.table[0];
        }
        let ([r, g, b], [fr, fg, fb]) = self.cell(rgb);
        // Corners by offsets (dr, dg, db).
        let p = |dr: usize, dg: usize, db: usize| self.at(r + dr, g + dg, b + db);
        let (v000, v111) = (p(0, 0, 0), p(1, 1, 1));
        // The path from 000 to 111 goes one axis at a time, largest
        // fraction first; weights are the differences of sorted fractions.
        let (first, second, f1, f2, f3) = if fr > fg {
            if fg > fb {
                (p(1, 0, 0), p(1, 1, 0), fr, fg, fb)
            } else if fr > fb {
                (p(1, 0, 0), p(1, 0, 1), fr, fb, fg)
            } else {
                (p(0, 0, 1), p(1, 0, 1), fb, fr, fg)
            }
        } else if fb > fg {
            (p(0, 0, 1), p(0, 1, 1), fb, fg, fr)
        } else if fb > fr {
            (p(0, 1, 0), p(0, 1, 1), fg, fb, fr)
        } else {
            (p(0, 1, 0), p(1, 1, 0), fg, fr, fb)
        };
        [0, 1, 2].map(|c| {
            (1.0 - f1) * v000[c] + (f1 - f2) * first[c] + (f2 - f3) * second[c] + f3 * v111[c]
        })
    }
}

impl Cdl {
    fn luma_mix(x: [f64; 3], sat: f64) -> [f64; 3] {
        let luma: f64 = (0..3).map(|i| REC709_LUMA[i] * x[i]).sum();
        x.map(|v| luma + sat * (v - luma))
    }

    fn forward(&self, x: [f64; 3]) -> [f64; 3] {
        let y = [0, 1, 2].map(|i| {
            (x[i] * self.slope[i] + self.offset[i])
                .clamp(0.0, 1.0)
                .powf(self.power[i])
        });
        Self::luma_mix(y, self.saturation).map(|v| v.clamp(0.0, 1.0))
    }

    fn reverse(&self, x: [f64; 3]) -> [f64; 3] {
        let x = x.map(|v| v.clamp(0.0, 1.0));
        let y = Self::luma_mix(x, 1.0 / self.saturation).map(|v| v.clamp(0.0, 1.0));
        [0, 1, 2].map(|i| (y[i].powf(1.0 / self.power[i]) - self.offset[i]) / self.slope[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() <= tol)
    }

    /// Fused matrices give what applying them one after the other gives.
    #[test]
    fn fused_matrices_equal_the_chain() {
        let a = Op::Matrix {
            m: [[0.9, 0.1, 0.0], [0.2, 0.7, 0.1], [0.0, 0.3, 0.8]],
            offset: [0.01, 0.0, -0.02],
        };
        let b = Op::Matrix {
            m: [[1.5, -0.3, 0.1], [0.0, 1.1, 0.0], [0.2, 0.0, 0.9]],
            offset: [0.0, 0.05, 0.0],
        };
        let chain = vec![
            a.clone(),
            b.clone(),
            Op::Log {
                base: 2.0,
                inverse: false,
            },
            a,
            b,
        ];
        let fused = fuse_matrices(chain.clone());
        assert_eq!(fused.len(), 3);
        let x = [0.3f32, 0.6, 0.2];
        let one = chain.iter().fold(x, |v, op| op.apply(v));
        let two = fused.iter().fold(x, |v, op| op.apply(v));
        assert!(close(one, two, 1e-6), "{one:?} {two:?}");
    }

    /// Every invertible operation undoes itself: matrix, log, power, the
    /// sRGB monitor curve (across its break point), a 1D LUT, the CDL.
    #[test]
    fn inverses_undo_their_operations() {
        let lut = Arc::new(Lut1d {
            table: (0..64)
                .map(|i| {
                    let t = i as f32 / 63.0;
                    [t * t, t.sqrt(), 0.2 + 0.5 * t]
                })
                .collect(),
        });
        let ops = [
            Op::Matrix {
                m: [
                    [3.24, -1.54, -0.50],
                    [-0.97, 1.88, 0.04],
                    [0.06, -0.20, 1.06],
                ],
                offset: [0.1, -0.2, 0.3],
            },
            Op::Log {
                base: 2.0,
                inverse: false,
            },
            Op::Pow {
                exponent: [2.4, 2.2, 1.0],
            },
            Op::MonCurve {
                gamma: 2.4,
                offset: 0.055,
                encode: true,
            },
            Op::Lut1d {
                lut,
                inverse: false,
            },
            Op::Cdl {
                cdl: Cdl {
                    slope: [1.1, 0.9, 1.0],
                    offset: [0.01, 0.0, -0.01],
                    power: [1.2, 1.0, 0.8],
                    saturation: 0.9,
                },
                inverse: false,
            },
        ];
        for op in &ops {
            for x in [[0.01f32, 0.2, 0.3], [0.002, 0.5, 0.45], [0.7, 0.35, 0.6]] {
                let there = op.apply(x);
                let back = op.inverse().unwrap().apply(there);
                assert!(
                    close(back, x, 2e-4),
                    "{op:?}: {x:?} -> {there:?} -> {back:?}"
                );
            }
        }
    }

    /// The sRGB curve's defining points: 0.18 encodes to 0.46135, 1 to 1;
    /// below the break (0.0030399, where the power law and the line meet
    /// with equal slope, as OCIO's curve: IEC 61966-2-1 rounds the slope
    /// to 12.92) the slope is 12.9232, for negatives too.
    #[test]
    fn moncurve_is_the_srgb_curve() {
        let enc = |x| moncurve(x, 2.4, 0.055, true);
        assert!((enc(0.003_039_934_6) - 0.039_285_71).abs() < 1e-7);
        assert!((enc(0.18) - 0.461_356).abs() < 1e-5, "{}", enc(0.18));
        assert!((enc(1.0) - 1.0).abs() < 1e-12);
        assert!((enc(0.001) - 0.012_923_2).abs() < 1e-7);
        assert!(
            (enc(-0.001) + 0.012_923_2).abs() < 1e-7,
            "negatives stay linear"
        );
    }

    /// Both interpolations reproduce a LUT of an affine map exactly
    /// (they are exact for linear functions) and its lattice points.
    #[test]
    fn lut3d_interpolations_are_exact_for_affine_maps() {
        let size = 5;
        let f = |x: [f32; 3]| {
            [
                0.5 * x[0] + 0.2 * x[1],
                x[1] - 0.3 * x[2] + 0.1,
                0.9 * x[2] + 0.05 * x[0],
            ]
        };
        let table = (0..size * size * size)
            .map(|i| {
                let (r, g, b) = (i % size, (i / size) % size, i / (size * size));
                f([r, g, b].map(|v| v as f32 / (size - 1) as f32))
            })
            .collect();
        let lut = Lut3d { size, table };
        for x in [
            [0.1f32, 0.7, 0.33],
            [0.9, 0.2, 0.6],
            [0.5, 0.5, 0.5],
            [0.31, 0.95, 0.02],
        ] {
            assert!(close(lut.tetrahedral(x), f(x), 1e-5), "{x:?}");
            assert!(close(lut.trilinear(x), f(x), 1e-5), "{x:?}");
        }
        // Beyond the cube the input is clamped.
        assert!(close(
            lut.tetrahedral([2.0, -1.0, 0.5]),
            f([1.0, 0.0, 0.5]),
            1e-5
        ));
    }

    /// Tetrahedral and trilinear differ on a non-linear table, and
    /// tetrahedral uses only the cell's main diagonal on grey.
    #[test]
    fn tetrahedral_interpolates_along_the_diagonal() {
        let size = 2;
        let mut table = vec![[0.0f32; 3]; 8];
        table[7] = [1.0; 3];
        let lut = Lut3d { size, table };
        // On the grey axis only 000 and 111 count.
        assert!(close(lut.tetrahedral([0.4; 3]), [0.4; 3], 1e-6));
        // Trilinear gives the product of the fractions.
        assert!(close(lut.trilinear([0.4; 3]), [0.064; 3], 1e-6));
    }
}
