//! Phase functions (closed enum): how a participating medium scatters
//! light, one plugin per file (`isotropic`, `hg`, `rayleigh`, `tabphase`,
//! `blendphase`, `sggx`), for the media of the volumetric integrators.
//!
//! `sggx` may vary over space: an integrator reads a medium's phase
//! function at the scattering point with [`PhaseFunction::at`], and the
//! medium scales its extinction by [`PhaseFunction::projected_area`].
//!
//! Conventions (Mitsuba 3's): `wo` points from the scattering point back
//! along the path (minus the incoming ray's direction), `wi` is the new
//! direction, and a phase function p(wo, wi) integrates to 1 over `wi`.
//! Every model here is sampled exactly in proportion to p, so a sample's
//! weight p / pdf is 1.

mod blendphase;
mod hg;
mod isotropic;
mod rayleigh;
mod sggx;
mod tabphase;

pub use blendphase::Blend;
pub use sggx::{SggxField, SggxMatrix};
pub use tabphase::Table;

use crate::params::{plugin_of, ParamError, Params};
use glam::{Vec2, Vec3};

/// A phase function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhaseFunction {
    /// `isotropic`: 1 / 4π.
    Isotropic,
    /// `hg`: Henyey–Greenstein with mean cosine `g`.
    HenyeyGreenstein {
        /// Mean cosine of the scattering angle, in (−1, 1).
        g: f32,
    },
    /// `rayleigh`: 3 (1 + cos²θ) / 16π.
    Rayleigh,
    /// `tabphase`: tabulated over cos θ (interned).
    Tabulated(&'static Table),
    /// `blendphase`: a mix of two (interned).
    Blend(&'static Blend),
    /// `sggx` whose matrix varies over space (interned): read it at a
    /// point with [`PhaseFunction::at`] before evaluating or sampling.
    Sggx(&'static SggxField),
    /// `sggx` with one matrix (or one read at a point).
    SggxAt(SggxMatrix),
}

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSample {
    /// The new direction (unit).
    pub wi: Vec3,
    /// Its solid-angle density.
    pub pdf: f32,
    /// p(wo, wi) / pdf (1 for every model here).
    pub weight: f32,
}

/// Builds a phase function plugin from its parameters.
pub type PhaseFromParams = fn(&mut dyn Params) -> Result<PhaseFunction, ParamError>;

/// Every phase function plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, PhaseFromParams)] = &[
    ("isotropic", |_| Ok(PhaseFunction::Isotropic)),
    ("hg", hg::from_params),
    ("rayleigh", |_| Ok(PhaseFunction::Rayleigh)),
    ("tabphase", tabphase::from_params),
    ("blendphase", blendphase::from_params),
    ("sggx", sggx::from_params),
];

impl Default for PhaseFunction {
    /// Mitsuba's default phase function.
    fn default() -> Self {
        PhaseFunction::Isotropic
    }
}

impl PhaseFunction {
    /// Builds the phase function `p` describes, by its plugin type.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        plugin_of(p, "phase", PLUGINS, None)?(p)
    }

    /// The phase function at world point `p` (only `sggx` varies).
    #[inline]
    pub fn at(&self, p: Vec3) -> PhaseFunction {
        match self {
            PhaseFunction::Sggx(field) => PhaseFunction::SggxAt(field.at(p)),
            other => *other,
        }
    }

    /// What a medium's extinction at `p` is multiplied by along direction
    /// `d` (unit): σ(d) = √(dᵀ S d) for `sggx`, 1 for the others.
    #[inline]
    pub fn projected_area(&self, p: Vec3, d: Vec3) -> f32 {
        match self {
            PhaseFunction::Sggx(field) => field.at(p).projected_area(d),
            PhaseFunction::SggxAt(s) => s.projected_area(d),
            _ => 1.0,
        }
    }

    /// An upper bound of [`PhaseFunction::projected_area`] anywhere.
    pub fn max_projected_area(&self) -> f32 {
        match self {
            PhaseFunction::Sggx(field) => field.max_projected_area(),
            PhaseFunction::SggxAt(s) => s.max_projected_area(),
            _ => 1.0,
        }
    }

    /// p(wo, wi) per steradian.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let cos_theta = wo.dot(wi);
        match self {
            PhaseFunction::Isotropic => isotropic::eval(),
            PhaseFunction::HenyeyGreenstein { g } => hg::eval(*g, cos_theta),
            PhaseFunction::Rayleigh => rayleigh::eval(cos_theta),
            PhaseFunction::Tabulated(t) => t.eval(cos_theta),
            PhaseFunction::Blend(b) => b.eval(wo, wi),
            PhaseFunction::Sggx(_) => unread_sggx(),
            PhaseFunction::SggxAt(s) => s.eval(wo, wi),
        }
    }

    /// The density [`PhaseFunction::sample`] gives `wi`: p itself.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval(wo, wi)
    }

    /// A new direction for the uniform sample `u`, in proportion to p.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> PhaseSample {
        let wi = match self {
            PhaseFunction::Isotropic => isotropic::sample(u),
            PhaseFunction::HenyeyGreenstein { g } => hg::sample(*g, wo, u),
            PhaseFunction::Rayleigh => rayleigh::sample(wo, u),
            PhaseFunction::Tabulated(t) => t.sample(wo, u),
            PhaseFunction::Blend(b) => b.sample(wo, u),
            PhaseFunction::Sggx(_) => unread_sggx(),
            PhaseFunction::SggxAt(s) => s.sample(wo, u),
        };
        PhaseSample {
            wi,
            pdf: self.pdf(wo, wi),
            weight: 1.0,
        }
    }
}

/// An `sggx` evaluated without being read at a point: a caller's error
/// (an integrator calls [`PhaseFunction::at`] first).
#[cold]
fn unread_sggx<T: Default>() -> T {
    debug_assert!(
        false,
        "an sggx phase function read without PhaseFunction::at"
    );
    T::default()
}

/// `local` (z the axis) turned so that its z is `-wo`: the direction the
/// path was travelling, about which the scattering angle is measured.
#[inline]
fn about_travel(wo: Vec3, cos_theta: f32, phi: f32) -> Vec3 {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let local = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
    crate::math::Frame::from_normal(-wo).to_world(local)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{chi2_directions, Chi2Config};

    /// Every phase function: isotropic, Henyey–Greenstein from strongly
    /// backward to strongly forward, Rayleigh.
    fn every_variant() -> Vec<PhaseFunction> {
        let mut v = vec![PhaseFunction::Isotropic, PhaseFunction::Rayleigh];
        v.extend([-0.9, -0.5, 0.0, 0.3, 0.9].map(|g| PhaseFunction::HenyeyGreenstein { g }));
        let table = |values: &[f32]| {
            PhaseFunction::Tabulated(Table::new(values.to_vec()).unwrap().interned())
        };
        // Two nodes, a forward peak with zeros, an uneven table.
        v.extend([
            table(&[1.0, 3.0]),
            table(&[0.0, 0.0, 0.1, 0.5, 4.0, 20.0]),
            table(&[1.0, 3.0, 2.0, 0.0, 2.5]),
        ]);
        let blend = |weight: f32, a: PhaseFunction, b: PhaseFunction| {
            PhaseFunction::Blend(
                Blend {
                    weight,
                    parts: [a, b],
                }
                .interned(),
            )
        };
        v.extend([
            blend(
                0.25,
                PhaseFunction::Isotropic,
                PhaseFunction::HenyeyGreenstein { g: 0.8 },
            ),
            blend(
                0.7,
                table(&[2.0, 0.5, 1.0]),
                PhaseFunction::HenyeyGreenstein { g: -0.6 },
            ),
            blend(0.0, PhaseFunction::Rayleigh, PhaseFunction::Isotropic),
        ]);
        // SGGX: flakes (S_zz small), fibres along z (S_zz large), and a
        // rotated, non-diagonal matrix.
        v.extend(sggx_matrices().map(|s| PhaseFunction::SggxAt(SggxMatrix(s))));
        v
    }

    fn sggx_matrices() -> [[f32; 6]; 3] {
        [
            [1.0, 1.0, 0.25, 0.0, 0.0, 0.0],
            [0.3, 0.3, 1.0, 0.0, 0.0, 0.0],
            [0.8, 0.5, 0.4, 0.2, -0.1, 0.15],
        ]
    }

    /// `sggx` against the paper's D(m) = 1 / (π √det S (mᵀ S⁻¹ m)²) with
    /// S⁻¹ computed here, and σ(ω) = √(ωᵀ S ω).
    #[test]
    fn sggx_evaluates_the_papers_formula() {
        for s in sggx_matrices() {
            let [xx, yy, zz, xy, xz, yz] = s;
            let m = glam::Mat3::from_cols_array(&[xx, xy, xz, xy, yy, yz, xz, yz, zz]);
            let f = PhaseFunction::SggxAt(SggxMatrix(s));
            for (wo, wi) in [
                (Vec3::Z, Vec3::X),
                (
                    Vec3::new(0.3, -0.5, 0.8).normalize(),
                    Vec3::new(-0.6, 0.1, 0.2).normalize(),
                ),
                (Vec3::X, Vec3::new(0.5, 0.5, 0.5).normalize()),
            ] {
                let h = (wo + wi).normalize();
                let d = 1.0
                    / (std::f32::consts::PI
                        * m.determinant().sqrt()
                        * h.dot(m.inverse() * h).powi(2));
                let sigma = wo.dot(m * wo).sqrt();
                let expected = d / (4.0 * sigma);
                let got = f.eval(wo, wi);
                assert!(
                    (got / expected - 1.0).abs() < 1e-4,
                    "{s:?}: {got} vs {expected}"
                );
                assert!((f.projected_area(Vec3::ZERO, wo) - sigma).abs() < 1e-6);
                assert!(f.projected_area(Vec3::ZERO, wo) <= f.max_projected_area());
            }
        }
        let flakes = SggxMatrix([1.0, 1.0, 0.25, 0.0, 0.0, 0.0]);
        assert!((flakes.projected_area(Vec3::Z) - 0.5).abs() < 1e-7);
        assert!((flakes.projected_area(Vec3::X) - 1.0).abs() < 1e-7);
    }

    /// The table-driven test: for every variant and a few incoming
    /// directions, sampled directions follow the density p (chi-square,
    /// Šidák-corrected over the table), weights are 1, and p integrates to
    /// 1 over the sphere.
    #[test]
    fn every_phase_function_variant() {
        let wos = [Vec3::Z, Vec3::new(0.3, -0.5, 0.8).normalize()];
        let variants = every_variant();
        let tests = variants.len() * wos.len();
        let cfg = Chi2Config {
            alpha: 1.0 - 0.99f64.powf(1.0 / tests as f64),
            integration_res: 16,
            ..Chi2Config::default()
        };
        let mut failures = Vec::new();
        for f in &variants {
            for wo in wos {
                let result = chi2_directions(
                    &cfg,
                    |r| {
                        let s = f.sample(wo, r.next_2d());
                        assert!((s.weight - 1.0).abs() < 1e-6);
                        Some((s.wi, s.pdf))
                    },
                    |wi| f.pdf(wo, wi),
                );
                if let Err(e) = result {
                    failures.push(format!("{f:?} wo={wo}: {e}"));
                }
                let integral = sphere_integral(|wi| f.eval(wo, wi));
                if (integral - 1.0).abs() > 2e-3 {
                    failures.push(format!("{f:?} wo={wo}: ∫ p = {integral}"));
                }
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// ∫ f over the sphere, midpoint rule in (cos θ, φ) about +z.
    fn sphere_integral(f: impl Fn(Vec3) -> f32) -> f64 {
        let (nt, np) = (2000, 200);
        let mut sum = 0.0f64;
        for i in 0..nt {
            let z = -1.0 + 2.0 * (i as f32 + 0.5) / nt as f32;
            let r = (1.0 - z * z).sqrt();
            for j in 0..np {
                let phi = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / np as f32;
                sum += f(Vec3::new(r * phi.cos(), r * phi.sin(), z)) as f64;
            }
        }
        sum * 4.0 * std::f64::consts::PI / (nt * np) as f64
    }

    /// Mitsuba 3's conventions: with g > 0 light keeps going (wi ≈ −wo),
    /// and the values of its `hg` and `rayleigh` plugins.
    #[test]
    fn forward_means_along_the_path_as_in_mitsuba() {
        let hg = PhaseFunction::HenyeyGreenstein { g: 0.7 };
        let wo = Vec3::Z;
        assert!(hg.eval(wo, -wo) > 10.0 * hg.eval(wo, wo));
        // p(θ) at cos θ = 1 in the travel direction: (1 − g²) / 4π(1 − g)³.
        let forward = (1.0 - 0.49) / (4.0 * std::f32::consts::PI * 0.3f32.powi(3));
        assert!((hg.eval(wo, -wo) / forward - 1.0).abs() < 1e-5);
        let r = PhaseFunction::Rayleigh;
        let along = 3.0 / (8.0 * std::f32::consts::PI);
        assert!((r.eval(wo, -wo) - along).abs() < 1e-6 && (r.eval(wo, wo) - along).abs() < 1e-6);
        assert!((r.eval(wo, Vec3::X) - along / 2.0).abs() < 1e-6);
    }

    /// `tabphase` as Mitsuba 3.9.1 evaluates and samples it (values read
    /// from its `scalar_rgb` variant): the table runs from backward to
    /// forward scattering, normalized by its trapezoid integral.
    #[test]
    fn tabphase_reads_its_table_as_mitsuba_does() {
        let t = Table::new(vec![1.0, 2.0, 3.0]).unwrap();
        let f = PhaseFunction::Tabulated(t.clone().interned());
        let two_pi = 2.0 * std::f32::consts::PI;
        let wo = Vec3::Z;
        let at = |mu: f32| {
            // wi at angle θ (cos θ = mu) to the direction of travel −wo.
            let s = (1.0 - mu * mu).sqrt();
            f.eval(wo, Vec3::new(s, 0.0, -mu)) * two_pi
        };
        for (mu, expected) in [(1.0, 0.75), (-1.0, 0.25), (0.0, 0.5), (0.8, 0.7)] {
            assert!((at(mu) - expected).abs() < 1e-6, "cos θ {mu}: {}", at(mu));
        }
        assert!((t.sample_mu(0.25) - (3f32.sqrt() - 2.0)).abs() < 1e-6);
        assert!((t.sample_mu(0.0) + 1.0).abs() < 1e-6 && (t.sample_mu(1.0) - 1.0).abs() < 1e-6);
        for bad in [vec![1.0], vec![0.0, 0.0], vec![1.0, -0.5]] {
            assert!(Table::new(bad).is_err());
        }
    }

    /// `blendphase`: the weight is the second one's share.
    #[test]
    fn blendphase_weights_the_second() {
        let wo = Vec3::Z;
        let hg = PhaseFunction::HenyeyGreenstein { g: 0.8 };
        let b = Blend {
            weight: 0.25,
            parts: [PhaseFunction::Isotropic, hg],
        };
        let expected = 0.75 / (4.0 * std::f32::consts::PI) + 0.25 * hg.eval(wo, Vec3::X);
        assert!((b.eval(wo, Vec3::X) - expected).abs() < 1e-7);
    }

    #[test]
    fn hg_refuses_g_outside_the_open_interval() {
        use crate::testing::params::MapParams;
        for g in [1.0, -1.0, 1.5, f32::NAN] {
            let mut p = MapParams::new().float("g", g);
            let e = hg::from_params(&mut p).unwrap_err().to_string();
            assert!(e.contains("\"g\""), "{e}");
        }
        let mut p = MapParams::new().float("g", -0.95);
        assert_eq!(
            hg::from_params(&mut p).unwrap(),
            PhaseFunction::HenyeyGreenstein { g: -0.95 }
        );
    }
}
