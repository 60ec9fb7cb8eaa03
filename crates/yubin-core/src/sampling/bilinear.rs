//! Points on [0, 1]² in proportion to the bilinear interpolation of four
//! corner weights, by a linear marginal in y and a linear conditional in
//! x, each inverted in closed form (Hart, Pharr, Müller, Lopes, McGuire
//! and Shirley 2020, "Practical Product Sampling by Fitting and Composing
//! Warps", Computer Graphics Forum 39(4); pbrt-v4 §A.5). Composed with a
//! light's own sampling, the warp tilts its samples toward the directions
//! a surface faces (the corners weighted by their cosines).

use glam::Vec2;

const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// A point of [0, 1) with density proportional to the line from `a` at 0
/// to `b` at 1 (both ≥ 0, not both 0): the inverse of its CDF,
/// (2a·x + (b − a)·x²)/(a + b) = u, in the form that does not cancel when
/// a ≈ b.
#[inline]
pub fn sample_linear(u: f32, a: f32, b: f32) -> f32 {
    if u == 0.0 && a == 0.0 {
        return 0.0;
    }
    let x = u * (a + b) / (a + (a * a + u * (b * b - a * a)).sqrt());
    x.min(ONE_MINUS_EPS)
}

/// Density of [`sample_linear`] at `x`.
#[inline]
pub fn linear_pdf(x: f32, a: f32, b: f32) -> f32 {
    2.0 * (a + x * (b - a)) / (a + b)
}

/// A point of [0, 1)² with density proportional to the bilinear
/// interpolation of `w` = [w(0, 0), w(1, 0), w(0, 1), w(1, 1)] (all ≥ 0,
/// not all 0).
#[inline]
pub fn sample_bilinear(u: Vec2, w: [f32; 4]) -> Vec2 {
    let y = sample_linear(u.y, w[0] + w[1], w[2] + w[3]);
    let x = sample_linear(u.x, w[0] + y * (w[2] - w[0]), w[1] + y * (w[3] - w[1]));
    Vec2::new(x, y)
}

/// Density of [`sample_bilinear`] at `p`.
#[inline]
pub fn bilinear_pdf(p: Vec2, w: [f32; 4]) -> f32 {
    let (x, y) = (p.x, p.y);
    let value =
        (1.0 - x) * (1.0 - y) * w[0] + x * (1.0 - y) * w[1] + (1.0 - x) * y * w[2] + x * y * w[3];
    4.0 * value / (w[0] + w[1] + w[2] + w[3])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::chi2_discrete;

    /// Samples fall in a grid's cells as the density integrates over them
    /// (chi-square), for even, tilted, lopsided and one-corner weights.
    #[test]
    fn chi2_bilinear_samples_follow_their_density() {
        let cases = [
            [1.0, 1.0, 1.0, 1.0],
            [0.2, 1.0, 0.5, 3.0],
            [5.0, 0.01, 0.01, 0.01],
            [0.0, 0.0, 0.0, 1.0],
        ];
        let cells = 16;
        for w in cases {
            let mut rng = Pcg32::new(3, 7);
            let n = 200_000;
            let mut counts = vec![0u64; cells * cells];
            for _ in 0..n {
                let p = sample_bilinear(rng.next_2d(), w);
                assert!(
                    (0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y),
                    "{p}"
                );
                let (i, j) = ((p.x * cells as f32) as usize, (p.y * cells as f32) as usize);
                counts[j * cells + i] += 1;
            }
            // The density integrated over each cell by a fine midpoint rule.
            let fine = 8;
            let expected: Vec<f64> = (0..cells * cells)
                .map(|c| {
                    let (i, j) = (c % cells, c / cells);
                    let mut sum = 0.0f64;
                    for a in 0..fine {
                        for b in 0..fine {
                            let p = Vec2::new(
                                (i as f32 + (a as f32 + 0.5) / fine as f32) / cells as f32,
                                (j as f32 + (b as f32 + 0.5) / fine as f32) / cells as f32,
                            );
                            sum += bilinear_pdf(p, w) as f64;
                        }
                    }
                    sum / (fine * fine) as f64 / (cells * cells) as f64 * n as f64
                })
                .collect();
            chi2_discrete(&counts, &expected, 0.01).unwrap_or_else(|e| panic!("{w:?}: {e}"));
        }
    }

    /// The inverse CDF: the density integrates to the u it came from.
    #[test]
    fn linear_samples_invert_their_cdf() {
        for (a, b) in [(1.0f32, 1.0f32), (0.0, 2.0), (3.0, 0.5), (1.0, 1.0001)] {
            for k in 0..=10 {
                let u = k as f32 / 10.0;
                let x = sample_linear(u, a, b);
                let cdf = (2.0 * a * x + (b - a) * x * x) / (a + b);
                assert!(
                    (cdf - u).abs() < 1e-5,
                    "a {a} b {b}: u {u} gave x {x}, cdf {cdf}"
                );
                assert!(linear_pdf(x, a, b) >= 0.0);
            }
        }
    }
}
