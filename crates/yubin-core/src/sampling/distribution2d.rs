//! Piecewise-constant distributions on [0, 1] and [0, 1]², sampled by
//! inverting their cumulative distribution functions: the 2D one picks a
//! row from the marginal, then a point in that row from its conditional
//! (pbrt-v4 §A.5.2–A.5.3; pbrt-v3 §13.6.7). Environment maps use it to
//! sample texels in proportion to their power.
//!
//! The inversion starts from a guide table (Chen & Asau 1974, "On
//! generating random variates from an empirical distribution"; Devroye,
//! *Non-Uniform Random Variate Generation*, 1986, §III.2.4): for each of
//! 2^k equal intervals of u, the step its start falls in. A sample then
//! searches only the CDF entries between two guides (a few, where the
//! density is spread; more, binary searched, where one bright texel's
//! step spans many intervals) instead of a table of megabytes, and finds
//! the same step. The guides cost one `u32` per interval (2^k ≥ steps).

use glam::Vec2;

/// A piecewise-constant density on [0, 1] made of `n` equal steps whose
/// heights are proportional to the weights it was built from.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    /// Step heights as given (negative and non-finite weights become 0).
    func: Vec<f32>,
    /// `n + 1` values from 0 to exactly 1.
    cdf: Vec<f32>,
    /// `G + 1` entries for `G` (a power of two, at least `n`): entry `k`
    /// is the step that u = k / G falls in.
    guide: Vec<u32>,
    /// ∫ func over [0, 1] (the mean weight); 0 when every weight was 0,
    /// in which case the density is uniform.
    integral: f32,
}

impl Distribution1D {
    /// From at least one weight.
    ///
    /// # Panics
    /// When `weights` is empty.
    pub fn new(weights: &[f32]) -> Self {
        Self::from_vec(weights.to_vec())
    }

    /// [`Distribution1D::new`] that keeps the weights' storage.
    ///
    /// # Panics
    /// When `weights` is empty.
    pub fn from_vec(mut func: Vec<f32>) -> Self {
        assert!(!func.is_empty(), "a distribution needs a weight");
        let n = func.len();
        for w in &mut func {
            if !(w.is_finite() && *w > 0.0) {
                *w = 0.0;
            }
        }
        // Summed in f64 so that a 4k row's CDF does not drift; the last
        // entry is set to exactly 1 so that `sample` cannot run off the end.
        // (The sum is taken twice rather than stored in f64.)
        let sum: f64 = func.iter().map(|&f| f as f64).sum();
        let integral = sum / n as f64;
        let cdf = if sum > 0.0 {
            let inv = 1.0 / sum;
            let mut running = 0.0f64;
            std::iter::once(0.0)
                .chain(func.iter().map(|&f| {
                    running += f as f64;
                    (running * inv) as f32
                }))
                .collect()
        } else {
            (0..=n).map(|i| i as f32 / n as f32).collect()
        };
        let mut d = Self {
            func,
            cdf,
            guide: Vec::new(),
            integral: integral as f32,
        };
        d.cdf[n] = 1.0;
        d.guide = d.guide_table();
        d
    }

    /// The guide table: for u = k / G, k = 0..=G, the step found by a
    /// search of the whole CDF (G a power of two, so that u · G is exact
    /// and k = ⌊u · G⌋ puts u at or after k / G and before (k + 1) / G).
    fn guide_table(&self) -> Vec<u32> {
        let n = self.func.len();
        let g = n.next_power_of_two();
        let mut guide = Vec::with_capacity(g + 1);
        let mut step = 0;
        for k in 0..=g {
            let u = k as f32 / g as f32;
            while step + 1 < n && self.cdf[step + 1] <= u {
                step += 1;
            }
            guide.push(step as u32);
        }
        guide
    }

    /// The last step whose CDF start is ≤ `u` (steps of weight 0 have zero
    /// width and are skipped by taking the last such start): a search of
    /// the CDF between the guides of the interval `u` falls in.
    #[inline]
    fn step_at(&self, u: f32) -> usize {
        let g = self.guide.len() - 1;
        // For u in [0, 1) (the contract of `sample`): k / G ≤ u < (k + 1) / G.
        let k = ((u * g as f32) as usize).min(g - 1);
        let (lo, hi) = (self.guide[k] as usize, self.guide[k + 1] as usize);
        // Every step up to `lo` starts at or before u, none after `hi`.
        lo + self.cdf[lo + 1..=hi].partition_point(|&c| c <= u)
    }

    /// Number of steps.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Always false (a distribution has at least one step).
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Mean of the weights (∫ of the step function over [0, 1]).
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// Density at step `i`.
    #[inline]
    fn step_pdf(&self, i: usize) -> f32 {
        if self.integral > 0.0 {
            self.func[i] / self.integral
        } else {
            1.0
        }
    }

    /// A point in [0, 1) for `u` in [0, 1): the point, its density and the
    /// step it fell in.
    #[inline]
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        let i = self.step_at(u);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let x = ((i as f32 + du) / n as f32).min(ONE_MINUS_EPS);
        (x, self.step_pdf(i), i)
    }

    /// The step containing `x` (clamped to [0, 1]).
    #[inline]
    pub fn step_of(&self, x: f32) -> usize {
        let n = self.func.len();
        ((x * n as f32) as usize).min(n - 1)
    }

    /// Density at `x` in [0, 1].
    #[inline]
    pub fn pdf(&self, x: f32) -> f32 {
        self.step_pdf(self.step_of(x))
    }
}

const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// A piecewise-constant density on [0, 1]² over a `width` × `height` grid
/// of cells (row-major, row 0 at y = 0), proportional to the cells' weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    /// One per row: the density of x given the row.
    conditional: Vec<Distribution1D>,
    /// The density of the row (weights: the rows' integrals).
    marginal: Distribution1D,
}

impl Distribution2D {
    /// From `width × height` weights, row by row.
    ///
    /// # Panics
    /// When the grid is empty or `weights` has another length.
    pub fn new(weights: &[f32], width: usize, height: usize) -> Self {
        assert!(width > 0 && height > 0 && weights.len() == width * height);
        let conditional: Vec<Distribution1D> = weights
            .chunks_exact(width)
            .map(Distribution1D::new)
            .collect();
        Self::from_rows(conditional)
    }

    /// From its rows' distributions (all of one length, at least one).
    ///
    /// # Panics
    /// When `conditional` is empty.
    pub fn from_rows(conditional: Vec<Distribution1D>) -> Self {
        let row_integrals: Vec<f32> = conditional.iter().map(|c| c.integral()).collect();
        Self {
            marginal: Distribution1D::new(&row_integrals),
            conditional,
        }
    }

    /// Cells per row.
    pub fn width(&self) -> usize {
        self.conditional[0].len()
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.conditional.len()
    }

    /// A point in [0, 1)² and its density with respect to area on the
    /// unit square.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (y, pdf_y, row) = self.marginal.sample(u.y);
        let (x, pdf_x, _) = self.conditional[row].sample(u.x);
        (Vec2::new(x, y), pdf_x * pdf_y)
    }

    /// Density at `p` (clamped to the unit square) with respect to area.
    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        let row = self.marginal.step_of(p.y);
        self.marginal.step_pdf(row) * self.conditional[row].pdf(p.x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::chi2_discrete;

    #[test]
    fn one_d_samples_steps_in_proportion_and_skips_zero_weights() {
        let w = [0.0, 2.0, 0.0, 0.0, 5.0, 1.0, 0.0];
        let d = Distribution1D::new(&w);
        assert!((d.integral() - 8.0 / 7.0).abs() < 1e-6);
        let n = 100_000;
        let mut counts = vec![0u64; w.len()];
        let mut rng = Pcg32::new(3, 1);
        for _ in 0..n {
            let (x, pdf, i) = d.sample(rng.next_f32());
            assert_eq!(d.step_of(x), i, "x = {x} is not in step {i}");
            assert_eq!(pdf, d.pdf(x));
            counts[i] += 1;
        }
        let expected: Vec<f64> = w.iter().map(|&v| v as f64 / 8.0 * n as f64).collect();
        chi2_discrete(&counts, &expected, 0.01).unwrap();
        assert_eq!(counts[0] + counts[2] + counts[3] + counts[6], 0);
        // The ends of [0, 1) map into the outer non-zero steps.
        assert_eq!(d.sample(0.0).2, 1);
        assert_eq!(d.sample(ONE_MINUS_EPS).2, 5);
    }

    /// The guided search finds the step a search of the whole CDF finds,
    /// for any u, at the CDF's own values and between them, for step
    /// counts at and between powers of two, with runs of zero weights and
    /// steps that span many guide intervals.
    #[test]
    fn guided_search_finds_the_whole_searchs_step() {
        let mut rng = Pcg32::new(11, 2);
        for n in [1, 2, 3, 7, 8, 9, 64, 100, 1000] {
            let weights: Vec<f32> = (0..n)
                .map(|i| match rng.next_u32() % 4 {
                    0 => 0.0,
                    1 if i % 5 == 0 => 1000.0,
                    _ => rng.next_f32(),
                })
                .collect();
            let d = Distribution1D::new(&weights);
            let whole = |u: f32| d.cdf[..n].partition_point(|&c| c <= u).saturating_sub(1);
            let mut us: Vec<f32> = d.cdf[..n].to_vec();
            us.extend(d.cdf[..n].iter().map(|&c| c.next_down().max(0.0)));
            us.extend((0..2000).map(|_| rng.next_f32()));
            us.extend([0.0, ONE_MINUS_EPS]);
            for u in us {
                assert_eq!(d.step_at(u), whole(u), "n = {n}, u = {u}, {weights:?}");
            }
        }
    }

    #[test]
    fn all_zero_weights_give_the_uniform_density() {
        let d = Distribution1D::new(&[0.0, 0.0, f32::NAN]);
        assert_eq!(d.pdf(0.7), 1.0);
        let (x, pdf, _) = d.sample(0.5);
        assert!((x - 0.5).abs() < 1e-6 && pdf == 1.0);
    }

    fn grid() -> (Vec<f32>, usize, usize) {
        let (w, h) = (7, 5);
        let weights = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                // A bright cell, a dark row and a spread of others.
                if (x, y) == (5, 1) {
                    40.0
                } else if y == 3 {
                    0.0
                } else {
                    ((x * 3 + y * 5) % 7) as f32 * 0.5
                }
            })
            .collect();
        (weights, w, h)
    }

    /// Points histogrammed by cell follow the weights (Pearson), and each
    /// sample's density is what `pdf` says.
    #[test]
    fn two_d_chi_square_over_cells() {
        let (weights, w, h) = grid();
        let d = Distribution2D::new(&weights, w, h);
        let total: f64 = weights.iter().map(|&v| v as f64).sum();
        let n = 200_000;
        let mut counts = vec![0u64; w * h];
        let mut rng = Pcg32::new(11, 2);
        for _ in 0..n {
            let (p, pdf) = d.sample(Vec2::new(rng.next_f32(), rng.next_f32()));
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
            let (cx, cy) = ((p.x * w as f32) as usize, (p.y * h as f32) as usize);
            let cell = cy * w + cx;
            assert!(weights[cell] > 0.0);
            let expected_pdf = weights[cell] as f64 / total * (w * h) as f64;
            assert!((pdf as f64 - expected_pdf).abs() < 1e-4 * expected_pdf);
            assert_eq!(pdf, d.pdf(p));
            counts[cell] += 1;
        }
        let expected: Vec<f64> = weights
            .iter()
            .map(|&v| v as f64 / total * n as f64)
            .collect();
        chi2_discrete(&counts, &expected, 0.01).unwrap();
    }

    #[test]
    fn two_d_pdf_integrates_to_one() {
        let (weights, w, h) = grid();
        let d = Distribution2D::new(&weights, w, h);
        let m = 140; // a multiple of both grid sizes: midpoints never sit on cell edges
        let mut sum = 0.0f64;
        for j in 0..m {
            for i in 0..m {
                let p = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                sum += d.pdf(p) as f64;
            }
        }
        let integral = sum / (m * m) as f64;
        assert!((integral - 1.0).abs() < 1e-5, "∫ pdf = {integral}");
    }
}
