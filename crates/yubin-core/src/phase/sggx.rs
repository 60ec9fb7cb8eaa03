//! `sggx`: the specular SGGX microflake phase function (Mitsuba 3's
//! `sggx`), for media of oriented fibres and flakes (cloth, foliage,
//! brushed volumes).
//!
//! | parameter | type   | default | meaning |
//! |-----------|--------|---------|---------|
//! | `S`       | volume | —       | a six-channel `gridvolume`: the symmetric matrix S as S_xx, S_yy, S_zz, S_xy, S_xz, S_yz at each voxel |
//!
//! ```xml
//! <medium type="heterogeneous">
//!     <phase type="sggx">
//!         <volume type="gridvolume" name="S">
//!             <string name="filename" value="fibres.vol"/>
//!         </volume>
//!     </phase>
//! </medium>
//! ```
//!
//! The microflakes' normals follow the SGGX distribution
//! D(m) = 1 / (π √det S (mᵀ S⁻¹ m)²) and reflect light specularly:
//! p(wo, wi) = D(h) / (4 σ(wo)), h the half vector of wo and wi, σ(ω) =
//! √(ωᵀ S ω) the flakes' area projected along ω. It is sampled exactly,
//! through the distribution of visible normals (Heitz et al. 2015,
//! appendix), so the weight is 1.
//!
//! The medium's extinction depends on the direction: σ_t is multiplied by
//! σ(ω) along the ray, S read at each point, in `homogeneous` and
//! `heterogeneous` media alike, as Mitsuba does
//! for its microflake phase functions. Mitsuba does not multiply a
//! heterogeneous medium's majorant by σ(ω), so where σ(ω) > 1 it takes
//! the smaller extinction (measured in Mitsuba 3.9.1: σ_t = 1 as a
//! gridvolume over a cube [−1, 1]³ with S = diag(1, 1, 4) transmits 0.135
//! ≈ e^−2 along z in a heterogeneous medium, 0.0176 ≈ e^−4 in a
//! homogeneous one: light made). yubin bounds σ(ω) by √ of the largest
//! eigenvalue of any S in the grid (Gershgorin's bound) and scales the
//! majorant by it, so both media transmit e^−4; where every eigenvalue is
//! at most 1 the two renderers //! agree.
//!
//! Mitsuba 3.9.1's `constvolume` cannot hold six values, so S is always a
//! `gridvolume` (a 1 × 1 × 1 grid for a constant S). The grid's values
//! are interpolated trilinearly as a volume's are. The diffuse SGGX
//! variant of the paper is not in Mitsuba 3 and not here.
//!
//! Reference: Heitz, Dupuy, Crassin and Dachsbacher 2015, "The SGGX
//! microflake distribution" (eqs. 9 and 11, appendix "Sampling the
//! distribution of visible normals"); Mitsuba 3 documentation,
//! "SGGX phase function (sggx)".

use super::PhaseFunction;
use crate::math::Frame;
use crate::params::{Family, ParamError, Params};
use crate::volume::{placed_grid, GridVolume};
use glam::{Vec2, Vec3};

/// Builds the phase function from its scene parameters.
pub(super) fn from_params(p: &mut dyn Params) -> Result<PhaseFunction, ParamError> {
    let Some(mut child) = p.named_child(Family::Volume, "S")? else {
        return Err(p.error("needs its matrix \"S\": a six-channel gridvolume"));
    };
    if child.plugin_type() != "gridvolume" {
        return Err(child.error(&format!(
            "S must be a six-channel gridvolume, not a {}",
            child.plugin_type()
        )));
    }
    let field = placed_grid(&mut *child)?;
    if field.grid.channels != 6 {
        return Err(child.param_error(
            "filename",
            &format!(
                "S needs 6 channels (S_xx, S_yy, S_zz, S_xy, S_xz, S_yz), the grid has {}",
                field.grid.channels
            ),
        ));
    }
    if field.grid.res == [1, 1, 1] {
        return Ok(PhaseFunction::SggxAt(SggxMatrix(
            field.grid.values()[..6].try_into().unwrap(),
        )));
    }
    Ok(PhaseFunction::Sggx(SggxField(field).interned()))
}

/// S over space: a six-channel grid.
#[derive(Clone, Debug, PartialEq)]
pub struct SggxField(pub GridVolume);

impl SggxField {
    /// The field stored for the program's life, once per content (so that
    /// a phase function stays a `Copy` value).
    pub fn interned(self) -> &'static SggxField {
        static INTERNED: std::sync::Mutex<Vec<&'static SggxField>> =
            std::sync::Mutex::new(Vec::new());
        crate::shape::interned(&INTERNED, self)
    }

    /// S at world point `p`.
    #[inline]
    pub fn at(&self, p: Vec3) -> SggxMatrix {
        SggxMatrix(self.0.eval6(p))
    }

    /// An upper bound of σ(ω) over every direction and every point.
    pub fn max_projected_area(&self) -> f32 {
        self.0
            .grid
            .values()
            .chunks_exact(6)
            .map(|s| SggxMatrix(s.try_into().unwrap()).max_projected_area())
            .fold(0.0, f32::max)
    }
}

/// A symmetric 3 × 3 matrix S: S_xx, S_yy, S_zz, S_xy, S_xz, S_yz.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SggxMatrix(pub [f32; 6]);

impl SggxMatrix {
    /// ωᵀ S ω.
    #[inline]
    fn quadratic_form(&self, w: Vec3) -> f32 {
        let [xx, yy, zz, xy, xz, yz] = self.0;
        w.x * w.x * xx
            + w.y * w.y * yy
            + w.z * w.z * zz
            + 2.0 * (w.x * w.y * xy + w.x * w.z * xz + w.y * w.z * yz)
    }

    /// σ(ω) = √(ωᵀ S ω): the flakes' area projected along `w` (unit).
    #[inline]
    pub fn projected_area(&self, w: Vec3) -> f32 {
        self.quadratic_form(w).max(0.0).sqrt()
    }

    /// An upper bound of σ(ω) over all directions: √ of Gershgorin's
    /// bound of the largest eigenvalue.
    pub fn max_projected_area(&self) -> f32 {
        let [xx, yy, zz, xy, xz, yz] = self.0;
        let rows = [
            xx + xy.abs() + xz.abs(),
            yy + xy.abs() + yz.abs(),
            zz + xz.abs() + yz.abs(),
        ];
        rows.into_iter().fold(0.0f32, f32::max).sqrt()
    }

    /// The microflake normal density D(m) (per steradian, projected-area
    /// normalized: ∫ D(m) ⟨ω, m⟩ dm = σ(ω) over the visible side),
    /// written det^(3/2) / (π (mᵀ adj(S) m)²) so that it needs no inverse.
    #[inline]
    fn normal_density(&self, m: Vec3) -> f32 {
        let [xx, yy, zz, xy, xz, yz] = self.0;
        let adj = SggxMatrix([
            yy * zz - yz * yz,
            xx * zz - xz * xz,
            xx * yy - xy * xy,
            xz * yz - xy * zz,
            xy * yz - xz * yy,
            xy * xz - xx * yz,
        ]);
        let det = (xx * adj.0[0] + xy * adj.0[3] + xz * adj.0[4]).abs();
        let q = adj.quadratic_form(m);
        if q <= 0.0 || det <= 0.0 {
            return 0.0;
        }
        det * det.sqrt() / (std::f32::consts::PI * q * q)
    }

    /// p(wo, wi): D of the half vector over 4 σ(wo).
    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let h = wo + wi;
        let sigma = self.projected_area(wo);
        if h.length_squared() <= 0.0 || sigma <= 0.0 {
            return 0.0;
        }
        self.normal_density(h.normalize()) / (4.0 * sigma)
    }

    /// A visible normal for `wo` (Heitz et al. 2015, appendix), mirrored:
    /// S in a frame whose third axis is `wo` gives three vectors that map
    /// a cosine-distributed direction to the visible normals.
    pub(super) fn sample(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let frame = Frame::from_normal(wo);
        let (k, j, i) = (frame.s, frame.t, frame.n);
        let bilinear = |a: Vec3, b: Vec3| {
            let [xx, yy, zz, xy, xz, yz] = self.0;
            let sb = Vec3::new(
                xx * b.x + xy * b.y + xz * b.z,
                xy * b.x + yy * b.y + yz * b.z,
                xz * b.x + yz * b.y + zz * b.z,
            );
            a.dot(sb)
        };
        let (s_kk, s_jj, s_ii) = (bilinear(k, k), bilinear(j, j), bilinear(i, i));
        let (s_kj, s_ki, s_ji) = (bilinear(k, j), bilinear(k, i), bilinear(j, i));
        let det =
            (s_kk * s_jj * s_ii - s_kj * s_kj * s_ii - s_ki * s_ki * s_jj - s_ji * s_ji * s_kk
                + 2.0 * s_kj * s_ki * s_ji)
                .abs();
        let tmp = (s_jj * s_ii - s_ji * s_ji).max(0.0).sqrt();
        let inv_sqrt_ii = 1.0 / s_ii.max(f32::MIN_POSITIVE).sqrt();
        if tmp <= 0.0 {
            // A degenerate S (flakes all facing wo): mirror straight back.
            return wo;
        }
        let m_k = Vec3::new(det.sqrt() / tmp, 0.0, 0.0);
        let m_j = inv_sqrt_ii * Vec3::new(-(s_ki * s_ji - s_kj * s_ii) / tmp, tmp, 0.0);
        let m_i = inv_sqrt_ii * Vec3::new(s_ki, s_ji, s_ii);
        let c = crate::sampling::square_to_cosine_hemisphere(u);
        let m_local = (c.x * m_k + c.y * m_j + c.z * m_i).normalize();
        let m = m_local.x * k + m_local.y * j + m_local.z * i;
        (2.0 * wo.dot(m) * m - wo).normalize()
    }
}
