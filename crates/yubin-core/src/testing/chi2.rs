//! Pearson's chi-square goodness-of-fit test for sampling routines.
//!
//! [`chi2_directions`] bins sampled unit vectors over the sphere in
//! (cos θ, φ) cells, integrates the claimed density over each cell
//! numerically, pools cells whose expected count is under 5, and rejects
//! the routine when the p-value falls below the significance level. On
//! failure the error holds both tables so the mismatch can be seen. This
//! is the method of Mitsuba's `ChiSquareTest` and pbrt's sampling tests,
//! written from the statistics.

use crate::sampler::Pcg32;
use glam::Vec3;
use std::f64::consts::PI;

/// Settings of a direction test.
#[derive(Clone, Copy, Debug)]
pub struct Chi2Config {
    /// Bins over cos θ ∈ [-1, 1].
    pub cos_theta_bins: usize,
    /// Bins over φ ∈ [0, 2π).
    pub phi_bins: usize,
    /// Number of samples drawn.
    pub samples: usize,
    /// Sub-cells per bin side for integrating the density.
    pub integration_res: usize,
    /// Significance level (before any multiple-test correction).
    pub alpha: f64,
    /// Seed of the random numbers fed to the routine.
    pub seed: u64,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Self {
            cos_theta_bins: 20,
            phi_bins: 40,
            samples: 200_000,
            integration_res: 8,
            alpha: 0.01,
            seed: 1,
        }
    }
}

/// What a sampling routine returns for one draw: a unit direction and the
/// density it claims for it, or `None` when it produced no sample.
pub type DirectionDraw = Option<(Vec3, f32)>;

/// Tests that `sample` draws directions with density `pdf`
/// (solid angle). `sample` gets a random-number generator; a draw that
/// returns `None` is lost mass, which shows up in Pearson's sum as missing
/// counts wherever `pdf` expected them. Also checks that each drawn
/// sample's claimed density agrees with `pdf` at that direction.
pub fn chi2_directions(
    cfg: &Chi2Config,
    mut sample: impl FnMut(&mut Pcg32) -> DirectionDraw,
    pdf: impl Fn(Vec3) -> f32,
) -> Result<(), String> {
    let (nt, np) = (cfg.cos_theta_bins, cfg.phi_bins);
    let mut observed = vec![0.0f64; nt * np];
    let mut rng = Pcg32::new(cfg.seed, 0x5eed);
    // Samples on the very edge of a shape's support may get density 0
    // from `pdf` through round-off; a handful is tolerated, more is a bug.
    let mut outside_support = 0usize;
    for _ in 0..cfg.samples {
        let Some((d, claimed)) = sample(&mut rng) else {
            continue;
        };
        if !d.is_finite() || (d.length() - 1.0).abs() > 1e-3 {
            return Err(format!("sampled direction {d} is not a unit vector"));
        }
        let actual = pdf(d);
        if actual == 0.0 {
            outside_support += 1;
        } else if claimed.is_finite() && (claimed - actual).abs() > 1e-3 * actual.max(1.0) {
            return Err(format!(
                "sample routine claims pdf {claimed} at {d}, pdf() says {actual}"
            ));
        }
        observed[bin_of(d, nt, np)] += 1.0;
    }
    if outside_support > cfg.samples / 1000 {
        return Err(format!(
            "{outside_support} of {} samples fell where pdf() is zero",
            cfg.samples
        ));
    }
    let expected = integrate_pdf_over_bins(&pdf, nt, np, cfg.integration_res, cfg.samples);
    chi2_test(&observed, &expected, cfg.alpha).map_err(|msg| {
        format!(
            "{msg}\nobserved (rows: cos θ from -1 to 1):\n{}\nexpected:\n{}",
            table(&observed, nt, np),
            table(&expected, nt, np)
        )
    })
}

/// Tests observed counts of a discrete distribution against expected ones.
pub fn chi2_discrete(counts: &[u64], expected: &[f64], alpha: f64) -> Result<(), String> {
    let obs: Vec<f64> = counts.iter().map(|&c| c as f64).collect();
    chi2_test(&obs, expected, alpha)
}

fn bin_of(d: Vec3, nt: usize, np: usize) -> usize {
    let ct = ((d.z as f64 + 1.0) * 0.5 * nt as f64).floor() as isize;
    let mut phi = (d.y as f64).atan2(d.x as f64);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let pb = (phi / (2.0 * PI) * np as f64).floor() as isize;
    let ct = ct.clamp(0, nt as isize - 1) as usize;
    let pb = pb.clamp(0, np as isize - 1) as usize;
    ct * np + pb
}

fn integrate_pdf_over_bins(
    pdf: &impl Fn(Vec3) -> f32,
    nt: usize,
    np: usize,
    res: usize,
    samples: usize,
) -> Vec<f64> {
    let coarse: Vec<(f64, bool)> = (0..nt * np)
        .map(|cell| integrate_cell(pdf, cell / np, cell % np, nt, np, res))
        .collect();
    // Cells on the edge of the support (some sub-cells zero, some not, or
    // empty next to a non-empty cell) hold discontinuities that midpoint
    // integration misses: integrate those again, much finer.
    let nonzero = |t: isize, p: isize| {
        let p = p.rem_euclid(np as isize) as usize;
        t >= 0 && (t as usize) < nt && coarse[t as usize * np + p].0 > 0.0
    };
    (0..nt * np)
        .map(|cell| {
            let (t, p) = ((cell / np) as isize, (cell % np) as isize);
            let (value, mixed) = coarse[cell];
            let near_support = (-1..=1).any(|dt| (-1..=1).any(|dp| nonzero(t + dt, p + dp)));
            let edge = mixed || (value == 0.0 && near_support);
            let (v, r) = if edge {
                let r = res * 8;
                (integrate_cell(pdf, t as usize, p as usize, nt, np, r).0, r)
            } else {
                (value, res)
            };
            // Lobes narrower than a sub-cell (glossy BSDFs with roughness
            // near 0.01) are integrated adaptively until the expected count
            // is known to a small fraction of its standard deviation.
            let (z0, z1, p0, p1) = cell_bounds(t as usize, p as usize, nt, np);
            refine(pdf, [z0, z1, p0, p1], v, r, samples as f64, 0) * samples as f64
        })
        .collect()
}

fn cell_bounds(t: usize, p: usize, nt: usize, np: usize) -> (f64, f64, f64, f64) {
    let (dz, dphi) = (2.0 / nt as f64, 2.0 * PI / np as f64);
    let z0 = -1.0 + dz * t as f64;
    let p0 = dphi * p as f64;
    (z0, z0 + dz, p0, p0 + dphi)
}

/// Adaptive refinement of `estimate`, the integral over `rect` (z0, z1,
/// φ0, φ1) at `res`² midpoints: the rectangle is split in four, each
/// quarter integrated at the same `res` (twice the resolution in all), and
/// quarters recursed into until the two estimates agree to 0.05 √(E + 1)
/// expected samples (E the expected count): the chi-square statistic then
/// carries a bias of at most about 0.0025 per cell.
fn refine(
    pdf: &impl Fn(Vec3) -> f32,
    rect: [f64; 4],
    estimate: f64,
    res: usize,
    samples: f64,
    depth: u32,
) -> f64 {
    const MAX_DEPTH: u32 = 6;
    let [z0, z1, p0, p1] = rect;
    let (zm, pm) = (0.5 * (z0 + z1), 0.5 * (p0 + p1));
    let quads = [
        [z0, zm, p0, pm],
        [zm, z1, p0, pm],
        [z0, zm, pm, p1],
        [zm, z1, pm, p1],
    ];
    let parts = quads.map(|q| integrate_rect(pdf, q, res).0);
    let fine: f64 = parts.iter().sum();
    let tol = 0.05 * (fine * samples + 1.0).sqrt() / samples / f64::from(1u32 << depth);
    if (fine - estimate).abs() <= tol || depth == MAX_DEPTH {
        return fine;
    }
    quads
        .iter()
        .zip(parts)
        .map(|(q, e)| refine(pdf, *q, e, res, samples, depth + 1))
        .sum()
}

/// Midpoint-rule integral of `pdf` over one (cos θ, φ) cell, and whether
/// the sub-samples were a mix of zero and non-zero densities.
fn integrate_cell(
    pdf: &impl Fn(Vec3) -> f32,
    t: usize,
    p: usize,
    nt: usize,
    np: usize,
    res: usize,
) -> (f64, bool) {
    let (z0, z1, p0, p1) = cell_bounds(t, p, nt, np);
    integrate_rect(pdf, [z0, z1, p0, p1], res)
}

/// Midpoint-rule integral of `pdf` over z ∈ [z0, z1], φ ∈ [φ0, φ1] with
/// `res`² points, and whether they were a mix of zero and non-zero.
fn integrate_rect(pdf: &impl Fn(Vec3) -> f32, rect: [f64; 4], res: usize) -> (f64, bool) {
    let [z0, z1, p0, p1] = rect;
    let (dz, dphi) = (z1 - z0, p1 - p0);
    let (mut sum, mut zeros) = (0.0, 0usize);
    for i in 0..res {
        for j in 0..res {
            let z = z0 + dz * (i as f64 + 0.5) / res as f64;
            let phi = p0 + dphi * (j as f64 + 0.5) / res as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            let v = pdf(d) as f64;
            zeros += usize::from(v == 0.0);
            sum += v;
        }
    }
    (
        sum * dz * dphi / (res * res) as f64,
        zeros > 0 && zeros < res * res,
    )
}

/// Pearson's test with pooling of cells whose expected count is below 5
/// (including cells with zero expectation: samples there inflate the
/// pooled cell's statistic and fail the test).
fn chi2_test(observed: &[f64], expected: &[f64], alpha: f64) -> Result<(), String> {
    let mut order: Vec<usize> = (0..observed.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pooled_obs, mut pooled_exp, mut chsq, mut dof) = (0.0, 0.0, 0.0, 0usize);
    for &i in &order {
        if expected[i] < 5.0 {
            pooled_obs += observed[i];
            pooled_exp += expected[i];
        } else {
            let diff = observed[i] - expected[i];
            chsq += diff * diff / expected[i];
            dof += 1;
        }
    }
    if pooled_exp > 0.0 || pooled_obs > 0.0 {
        let diff = pooled_obs - pooled_exp;
        chsq += diff * diff / pooled_exp.max(1e-12);
        dof += 1;
    }
    if dof < 2 {
        return Err(format!(
            "only {dof} usable cells: the test would be meaningless"
        ));
    }
    let dof = dof - 1;
    let p = chi2_survival(chsq, dof as f64);
    if p < alpha {
        Err(format!(
            "chi-square test rejected the sampler: χ² = {chsq:.1} with {dof} degrees of freedom, p = {p:.3e} < {alpha}"
        ))
    } else {
        Ok(())
    }
}

/// P(X ≥ x) for a chi-square variable with `k` degrees of freedom: the
/// regularized upper incomplete gamma Q(k/2, x/2), by series or continued
/// fraction (Numerical Recipes, 3rd ed., §6.2).
pub fn chi2_survival(x: f64, k: f64) -> f64 {
    let (a, x) = (k / 2.0, x / 2.0);
    if x <= 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        1.0 - gamma_series(a, x)
    } else {
        gamma_continued_fraction(a, x)
    }
}

fn ln_gamma(x: f64) -> f64 {
    // Lanczos approximation, g = 7, n = 9.
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let t = x + 7.5;
    let s: f64 = C[0] + (1..9).map(|i| C[i] / (x + i as f64)).sum::<f64>();
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

fn gamma_series(a: f64, x: f64) -> f64 {
    let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
    for _ in 0..10_000 {
        ap += 1.0;
        term *= x / ap;
        sum += term;
        if term.abs() < sum.abs() * 1e-15 {
            break;
        }
    }
    sum * (-x + a * x.ln() - ln_gamma(a)).exp()
}

fn gamma_continued_fraction(a: f64, x: f64) -> f64 {
    let tiny = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..10_000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < tiny {
            d = tiny;
        }
        c = b + an / c;
        if c.abs() < tiny {
            c = tiny;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    (-x + a * x.ln() - ln_gamma(a)).exp() * h
}

fn table(v: &[f64], nt: usize, np: usize) -> String {
    (0..nt)
        .map(|t| {
            v[t * np..(t + 1) * np]
                .iter()
                .map(|x| format!("{x:6.0}"))
                .collect::<String>()
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{square_to_uniform_sphere, UNIFORM_SPHERE_PDF};

    #[test]
    fn survival_function_known_values() {
        // Table values: P(χ²₁ ≥ 3.841) = 0.05, P(χ²₁₀ ≥ 23.209) = 0.01.
        assert!((chi2_survival(3.841, 1.0) - 0.05).abs() < 1e-3);
        assert!((chi2_survival(23.209, 10.0) - 0.01).abs() < 1e-4);
        assert!((chi2_survival(100.0, 100.0) - 0.4810).abs() < 1e-3);
    }

    #[test]
    fn accepts_a_correct_sampler() {
        chi2_directions(
            &Chi2Config::default(),
            |r| Some((square_to_uniform_sphere(r.next_2d()), UNIFORM_SPHERE_PDF)),
            |_| UNIFORM_SPHERE_PDF,
        )
        .unwrap();
    }

    #[test]
    fn rejects_a_wrong_sampler() {
        // Directions biased towards +z while claiming uniformity.
        let res = chi2_directions(
            &Chi2Config::default(),
            |r| {
                let mut u = r.next_2d();
                u.x *= 0.95;
                Some((square_to_uniform_sphere(u), f32::NAN))
            },
            |_| UNIFORM_SPHERE_PDF,
        );
        assert!(res.is_err());
    }
}
