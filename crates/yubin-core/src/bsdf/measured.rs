//! `measured`: a measured material from the RGL database (Mitsuba 3's
//! `measured`), read from its `.bsdf` tensor file and evaluated and
//! importance sampled through the adaptive parameterization of Dupuy &
//! Jakob 2018.
//!
//! | parameter  | type   | default | meaning |
//! |------------|--------|---------|---------|
//! | `filename` | string | —       | an RGB `.bsdf` file (RGL material database format) |
//!
//! ```xml
//! <bsdf type="measured">
//!     <string name="filename" value="cc_ibiza_sunset_rgb.bsdf"/>
//! </bsdf>
//! ```
//!
//! **The file** is Mitsuba's tensor file: the magic `tensor_file\0`, a
//! version (1, 0), a field count, then per field its name, rank, type
//! code, data offset and shape; data little-endian, row-major. The fields
//! read: `theta_i` and `phi_i` (the incident directions measured, radians),
//! `ndf` and `sigma` (the microfacet normal distribution D and its
//! projected area σ, on the square below), `vndf` and `luminance` (per
//! incident direction: the visible normals' density and the sampling
//! density of the measurement), `rgb` (per incident direction, 3 channels
//! of the measurement over the sample square), `jacobian` and
//! `description`. Spectral files (`wavelengths`, `spectra`) are refused:
//! yubin renders in RGB, as Mitsuba's `*_rgb` variants do.
//!
//! **The model** (paper §4–5): a direction (θ, φ) is the point u = (√(2θ/π),
//! (φ + π)/2π) of the unit square. For an incident direction ωi (towards
//! the viewer) the half vector ωm of ωi and ωo is looked up in the
//! visible-normal warp, whose inverse gives the sample point s where the
//! measurement lies; the value is rgb(s) × D(ωm) / (4 σ(ωi)) when
//! `jacobian` is set, rgb(s) otherwise, and already includes cos θo. Each
//! table is bilinear over its square and linear between the incident
//! directions measured; the `vndf` and `luminance` tables are warps
//! (normalized, inverted exactly through their row and column integrals),
//! and sampling goes luminance → sample point → visible normal → mirror
//! direction, so the density is p_vndf p_lum / (2π² u_x sin θm · 4 ωi·ωm)
//! (a sample's value and density are recomputed from its direction, which
//! near the square's pole, where the density grows as 1/u_x², rounding
//! would otherwise set apart from `pdf`'s).
//! Isotropic files (`phi_i` of 1 or 2 values) are tabulated over φm − φi;
//! anisotropic ones over absolute azimuths, folded by their symmetry
//! (`phi_i` spanning π: a half-turn about the normal; π/2: mirrors in x
//! and y). One-sided glossy reflection.
//!
//! As measured in Mitsuba 3.9.1 with a tabulated GGX written in this
//! format (`scripts/make-tabulated-bsdf.py`): values and densities agree to
//! 10⁻⁵ away from the exact mirror direction. There, and at ωi exactly
//! along the normal, Mitsuba folds isotropic files by a symmetry it never
//! set (an uninitialized member): yubin does not fold them.
//!
//! Reference: Dupuy & Jakob 2018, "An adaptive parameterization for
//! efficient material acquisition and rendering" (ACM TOG 37(6));
//! Mitsuba 3 documentation, "Measured material (measured)".

use super::{BsdfContext, BsdfFlags, BsdfSample, Scatter};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A measured material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    /// Its tables (interned).
    pub data: &'static MeasuredData,
}

impl Measured {
    /// Builds the BSDF from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let Some(bytes) = p.file_bytes("filename")? else {
            return Err(p.error("needs a \"filename\": an RGL .bsdf file"));
        };
        let file = p.string("filename")?.unwrap_or_default();
        let data = MeasuredData::parse(&bytes)
            .map_err(|e| p.param_error("filename", &format!("{file}: {e}")))?;
        Ok(Self {
            data: data.interned(),
        })
    }

    /// Lobes this material has.
    pub fn flags(&self, _: &Materials) -> BsdfFlags {
        BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::FRONT_SIDE
    }

    /// The lobe at `si`.
    #[inline]
    pub fn lobe(&self, _: &Materials, _: &SurfaceInteraction) -> MeasuredLobe {
        MeasuredLobe { data: self.data }
    }
}

/// [`Measured`] at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredLobe {
    /// The tables.
    pub data: &'static MeasuredData,
}

/// A measured material's tables.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredData {
    /// The incident elevations measured.
    theta_i: Vec<f32>,
    /// The incident azimuths measured.
    phi_i: Vec<f32>,
    /// Tabulated over φm − φi.
    isotropic: bool,
    /// The symmetry an anisotropic file is folded by (1: none).
    reduction: u32,
    /// Values are divided by the visible-normal warp's density.
    jacobian: bool,
    /// D(ωm) over the square.
    ndf: Table2D,
    /// σ(ωi) over the square.
    sigma: Table2D,
    /// The visible normals' warp, per incident direction.
    vndf: Table2D,
    /// The sampling warp, per incident direction.
    luminance: Table2D,
    /// The measurement, per incident direction and channel.
    rgb: Table2D,
    /// What the file says it is.
    pub description: String,
}

impl MeasuredData {
    /// The tables stored for the program's life, once per content.
    pub fn interned(self) -> &'static MeasuredData {
        static INTERNED: std::sync::Mutex<Vec<&'static MeasuredData>> =
            std::sync::Mutex::new(Vec::new());
        crate::shape::interned(&INTERNED, self)
    }

    /// The material in the bytes of a `.bsdf` file, checked.
    pub fn parse(bytes: &[u8]) -> Result<MeasuredData, String> {
        let file = TensorFile::parse(bytes)?;
        if file.find("wavelengths").is_some() {
            return Err(
                "holds spectral measurements (wavelengths, spectra): yubin renders in RGB, as \
                 Mitsuba's *_rgb variants do; use the file's RGB version"
                    .into(),
            );
        }
        let floats = |name: &str, rank: usize| -> Result<(Vec<usize>, Vec<f32>), String> {
            let f = file.field(name)?;
            if f.dtype != DType::F32 || f.shape.len() != rank {
                return Err(format!(
                    "field \"{name}\" must be float32 of rank {rank}, not {:?} of shape {:?}",
                    f.dtype, f.shape
                ));
            }
            let values = f.f32_values();
            if let Some(v) = values.iter().find(|v| !v.is_finite()) {
                return Err(format!("field \"{name}\" holds {v}"));
            }
            Ok((f.shape.clone(), values))
        };
        let (_, theta_i) = floats("theta_i", 1)?;
        let (_, phi_i) = floats("phi_i", 1)?;
        let (pt, pp) = (theta_i.len(), phi_i.len());
        if pt == 0 || pp == 0 {
            return Err("theta_i and phi_i need at least one value each".into());
        }
        let ascending = |v: &[f32]| v.windows(2).all(|w| w[0] < w[1]);
        if !ascending(&theta_i) || !ascending(&phi_i) {
            return Err("theta_i and phi_i must be ascending".into());
        }
        let jacobian = file.field("jacobian")?;
        if jacobian.dtype != DType::U8 || jacobian.shape != [1] {
            return Err(format!(
                "field \"jacobian\" must be one uint8, not {:?} of shape {:?}",
                jacobian.dtype, jacobian.shape
            ));
        }
        let description = file.field("description")?;
        if description.dtype != DType::U8 || description.shape.len() != 1 {
            return Err("field \"description\" must be uint8 text".into());
        }
        let (ndf_shape, ndf) = floats("ndf", 2)?;
        let (sigma_shape, sigma) = floats("sigma", 2)?;
        let (vndf_shape, vndf) = floats("vndf", 4)?;
        let (lum_shape, luminance) = floats("luminance", 4)?;
        let (rgb_shape, rgb) = floats("rgb", 5)?;
        let per_direction = |name: &str, shape: &[usize]| {
            if shape[0] != pp || shape[1] != pt {
                Err(format!(
                    "field \"{name}\" has shape {shape:?}: it must start with len(phi_i) = {pp}, \
                     len(theta_i) = {pt}"
                ))
            } else {
                Ok(())
            }
        };
        per_direction("vndf", &vndf_shape)?;
        per_direction("luminance", &lum_shape)?;
        per_direction("rgb", &rgb_shape)?;
        let n = lum_shape[2];
        if lum_shape[3] != n || rgb_shape[2] != 3 || rgb_shape[3] != n || rgb_shape[4] != n {
            return Err(format!(
                "luminance {lum_shape:?} must be square and rgb {rgb_shape:?} of shape \
                 [{pp}, {pt}, 3, N, N] with the same N"
            ));
        }
        let directions = vec![phi_i.clone(), theta_i.clone()];
        let mut channels = directions.clone();
        channels.push(vec![0.0, 1.0, 2.0]);
        let isotropic = pp <= 2;
        let reduction = if isotropic {
            1
        } else {
            (2.0 * PI / (phi_i[pp - 1] - phi_i[0])).round().max(1.0) as u32
        };
        Ok(MeasuredData {
            isotropic,
            reduction,
            jacobian: jacobian.bytes[0] != 0,
            ndf: Table2D::new(&ndf_shape, ndf, Vec::new(), false)?,
            sigma: Table2D::new(&sigma_shape, sigma, Vec::new(), false)?,
            vndf: Table2D::new(&vndf_shape[2..], vndf, directions.clone(), true)?,
            luminance: Table2D::new(&lum_shape[2..], luminance, directions, true)?,
            rgb: Table2D::new(&rgb_shape[3..], rgb, channels, false)?,
            description: String::from_utf8_lossy(description.bytes).into_owned(),
            theta_i,
            phi_i,
        })
    }

    /// Whether the file is tabulated over φm − φi (so the material turns
    /// freely about the normal).
    pub fn is_isotropic(&self) -> bool {
        self.isotropic
    }

    /// The parameters a direction's tables are read at: (φi, θi).
    #[inline]
    fn incident(&self, wi: Vec3) -> (f32, f32) {
        (azimuth(wi), elevation(wi))
    }

    /// (ωi, ωo) folded by the material's symmetry, and the fold, which is
    /// its own inverse.
    #[inline]
    fn fold(&self, wi: Vec3) -> Vec3 {
        let flip = |c: f32| if c.is_sign_positive() { -1.0 } else { 1.0 };
        match self.reduction {
            0 | 1 => Vec3::ONE,
            4 => Vec3::new(flip(wi.x), flip(wi.y), 1.0),
            _ => {
                let f = flip(wi.y);
                Vec3::new(f, f, 1.0)
            }
        }
    }

    /// The half vector's point on the square (azimuth relative to ωi's
    /// for isotropic files).
    #[inline]
    fn half_vector_point(&self, wm: Vec3, phi_i: f32) -> Vec2 {
        let phi = if self.isotropic {
            azimuth(wm) - phi_i
        } else {
            azimuth(wm)
        };
        let u = square_point(elevation(wm), phi);
        Vec2::new(u.x, u.y - u.y.floor())
    }

    /// The value at sample point `s` for incident (φi, θi), the half
    /// vector at `u_m` and the incident direction at `u_wi`.
    #[inline]
    fn value(&self, s: Vec2, phi_i: f32, theta_i: f32, u_m: Vec2, u_wi: Vec2) -> Rgb {
        let r = Rgb::new(
            self.rgb.eval(s, &[phi_i, theta_i, 0.0]),
            self.rgb.eval(s, &[phi_i, theta_i, 1.0]),
            self.rgb.eval(s, &[phi_i, theta_i, 2.0]),
        );
        if self.jacobian {
            r * (self.ndf.eval(u_m, &[]) / (4.0 * self.sigma.eval(u_wi, &[])))
        } else {
            r
        }
    }

    /// (f cos θo, pdf) for viewer direction `wi` and light direction `wo`
    /// (the paper's names; both local, above the surface).
    fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let f = self.fold(wi);
        let (wi, wo) = (wi * f, wo * f);
        let wm = (wi + wo).normalize();
        let (phi_i, theta_i) = self.incident(wi);
        let u_m = self.half_vector_point(wm, phi_i);
        let u_wi = square_point(theta_i, phi_i);
        let (s, p_vndf) = self.vndf.invert(u_m, &[phi_i, theta_i]);
        let value = self.value(s, phi_i, theta_i, u_m, u_wi);
        let p_lum = self.luminance.eval(s, &[phi_i, theta_i]);
        let pdf = p_vndf * p_lum / reflection_jacobian(u_m.x, wm.z, wi.dot(wm));
        (value, pdf)
    }
}

/// The Jacobian from the half vector's point on the square to the
/// reflected direction's solid angle: 2π² u_x sin θm (square → ωm, at
/// least 10⁻⁶ as Mitsuba takes it) × 4 ωi·ωm (ωm → ωo).
#[inline]
fn reflection_jacobian(u_x: f32, cos_m: f32, i_dot_m: f32) -> f32 {
    let sin_m = (1.0 - cos_m * cos_m).max(0.0).sqrt();
    (2.0 * PI * PI * u_x * sin_m).max(1e-6) * 4.0 * i_dot_m
}

/// Elevation from +z, accurate near the pole: 2 asin(|ω − z| / 2).
#[inline]
fn elevation(w: Vec3) -> f32 {
    2.0 * (0.5 * Vec3::new(w.x, w.y, w.z - 1.0).length())
        .min(1.0)
        .asin()
}

#[inline]
fn azimuth(w: Vec3) -> f32 {
    w.y.atan2(w.x)
}

/// The paper's square: (√(2θ/π), (φ + π) / 2π).
#[inline]
fn square_point(theta: f32, phi: f32) -> Vec2 {
    Vec2::new((2.0 * theta / PI).max(0.0).sqrt(), (phi + PI) * (0.5 / PI))
}

impl Scatter for MeasuredLobe {
    fn sample(&self, _: &BsdfContext, wo: Vec3, _u1: f32, u2: Vec2) -> Option<BsdfSample> {
        // The paper's ωi is yubin's wo (towards the viewer).
        let d = self.data;
        if wo.z <= 0.0 {
            return None;
        }
        let f = d.fold(wo);
        let wi_paper = wo * f;
        let (phi_i, theta_i) = d.incident(wi_paper);
        let params = [phi_i, theta_i];
        let (s, _) = d.luminance.sample(Vec2::new(u2.y, u2.x), &params);
        let (u_m, _) = d.vndf.sample(s, &params);
        let theta_m = u_m.x * u_m.x * (0.5 * PI);
        let mut phi_m = (2.0 * u_m.y - 1.0) * PI;
        if d.isotropic {
            phi_m += phi_i;
        }
        let (sin_t, cos_t) = theta_m.sin_cos();
        let (sin_p, cos_p) = phi_m.sin_cos();
        let wm = Vec3::new(cos_p * sin_t, sin_p * sin_t, cos_t);
        let wo_paper = 2.0 * wi_paper.dot(wm) * wm - wi_paper;
        let wi = wo_paper * f;
        // The value and density of the direction itself: the warps' own
        // (p_vndf p_lum / Jacobian) differ from them by rounding near the
        // pole of the half vector's square, where the density grows as
        // 1/u_x² (and MIS needs the two to agree).
        let (value, pdf) = d.eval_pdf(wo, wi);
        if wi.z <= 0.0 || !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
            weight: value / pdf,
        })
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> Rgb {
        self.data.eval_pdf(wo, wi).0
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, wo: Vec3, wi: Vec3) -> f32 {
        self.data.eval_pdf(wo, wi).1
    }
}

/// A bilinear table over [0, 1]² (W columns along x, H rows along y),
/// one slice per combination of its parameters' nodes, linear between
/// them; a warp (normalized, with the integrals that invert it) or plain
/// values.
#[derive(Clone, Debug, PartialEq)]
struct Table2D {
    width: usize,
    height: usize,
    /// Each parameter's nodes (the first varies slowest over slices).
    params: Vec<Vec<f32>>,
    /// Slices × H × W values.
    data: Vec<f32>,
    /// Slices × H × (W − 1): each row's integral up to each column's end.
    cond: Vec<f32>,
    /// Slices × (H − 1): the rows' integral up to each row's end.
    marg: Vec<f32>,
}

impl Table2D {
    /// A table of `shape` [H, W] from `data`; a warp when `warp` (each
    /// slice scaled to integrate to 1, its integrals kept).
    fn new(
        shape: &[usize],
        data: Vec<f32>,
        params: Vec<Vec<f32>>,
        warp: bool,
    ) -> Result<Self, String> {
        let (height, width) = (shape[0], shape[1]);
        if width < 2 || height < 2 {
            return Err(format!(
                "a table of {height} × {width}: each side needs at least 2 values"
            ));
        }
        let slices = data.len() / (width * height);
        let mut t = Table2D {
            width,
            height,
            params,
            data,
            cond: Vec::new(),
            marg: Vec::new(),
        };
        if warp {
            if t.data.iter().any(|v| *v < 0.0) {
                return Err("a warp table (vndf, luminance) holds a negative value".into());
            }
            for slice in 0..slices {
                t.integrate(slice)?;
            }
        }
        Ok(t)
    }

    /// Normalizes slice `slice` and appends its row and column integrals.
    fn integrate(&mut self, slice: usize) -> Result<(), String> {
        let (w, h) = (self.width, self.height);
        let values = &mut self.data[slice * w * h..(slice + 1) * w * h];
        let mut cond = vec![0.0f64; h * (w - 1)];
        for y in 0..h {
            let mut sum = 0.0f64;
            for x in 0..w - 1 {
                sum += (values[y * w + x] as f64 + values[y * w + x + 1] as f64)
                    / (2.0 * (w - 1) as f64);
                cond[y * (w - 1) + x] = sum;
            }
        }
        let row = |y: usize| cond[y * (w - 1) + w - 2];
        let mut sum = 0.0f64;
        let marg: Vec<f64> = (0..h - 1)
            .map(|y| {
                sum += (row(y) + row(y + 1)) / (2.0 * (h - 1) as f64);
                sum
            })
            .collect();
        let total = sum;
        if total.is_nan() || total <= 0.0 {
            return Err("a warp table (vndf, luminance) has a slice of zeros".into());
        }
        for v in values.iter_mut() {
            *v = (*v as f64 / total) as f32;
        }
        self.cond.extend(cond.iter().map(|c| (c / total) as f32));
        self.marg.extend(marg.iter().map(|m| (m / total) as f32));
        Ok(())
    }

    /// The slices around parameters `p` and their weights (at most 8).
    #[inline]
    fn corners(&self, p: &[f32]) -> Corners {
        let (mut slices, mut weights, mut n) = ([0usize; 8], [0f32; 8], 1usize);
        weights[0] = 1.0;
        for (nodes, &value) in self.params.iter().zip(p) {
            let count = nodes.len();
            // Existing corners move to this dimension's first node.
            for s in &mut slices[..n] {
                *s *= count;
            }
            if count == 1 {
                continue;
            }
            let below = nodes.iter().take_while(|&&v| v < value).count();
            let i = below.saturating_sub(1).min(count - 2);
            let t = ((value - nodes[i]) / (nodes[i + 1] - nodes[i])).clamp(0.0, 1.0);
            for k in 0..n {
                slices[n + k] = slices[k] + i + 1;
                weights[n + k] = weights[k] * t;
                slices[k] += i;
                weights[k] *= 1.0 - t;
            }
            n *= 2;
        }
        Corners { slices, weights, n }
    }

    #[inline]
    fn at(&self, slice: usize, x: usize, y: usize) -> f32 {
        self.data[(slice * self.height + y) * self.width + x]
    }

    #[inline]
    fn cond_at(&self, slice: usize, x: usize, y: usize) -> f32 {
        self.cond[(slice * self.height + y) * (self.width - 1) + x]
    }

    /// A row's whole integral.
    #[inline]
    fn row_total(&self, slice: usize, y: usize) -> f32 {
        self.cond_at(slice, self.width - 2, y)
    }

    #[inline]
    fn marg_at(&self, slice: usize, y: usize) -> f32 {
        self.marg[slice * (self.height - 1) + y]
    }

    /// The cell of `pos` and the position in it.
    #[inline]
    fn cell(&self, pos: Vec2) -> (usize, usize, f32, f32) {
        let gx = pos.x.clamp(0.0, 1.0) * (self.width - 1) as f32;
        let gy = pos.y.clamp(0.0, 1.0) * (self.height - 1) as f32;
        let ix = (gx as usize).min(self.width - 2);
        let iy = (gy as usize).min(self.height - 2);
        (ix, iy, gx - ix as f32, gy - iy as f32)
    }

    /// The bilinear value at `pos`.
    #[inline]
    fn eval(&self, pos: Vec2, p: &[f32]) -> f32 {
        let at_p = self.corners(p);
        let (ix, iy, fx, fy) = self.cell(pos);
        at_p.blend(|s| {
            let row = |y| lerp(self.at(s, ix, y), self.at(s, ix + 1, y), fx);
            lerp(row(iy), row(iy + 1), fy)
        })
    }

    /// The warp's sample point for `pos` (the inverse of
    /// [`Table2D::sample`]) and the density there.
    fn invert(&self, pos: Vec2, p: &[f32]) -> (Vec2, f32) {
        let at_p = self.corners(p);
        let (ix, iy, fx, fy) = self.cell(pos);
        let v = |x, y| at_p.blend(|s| self.at(s, x, y));
        let c0 = lerp(v(ix, iy), v(ix, iy + 1), fy);
        let c1 = lerp(v(ix + 1, iy), v(ix + 1, iy + 1), fy);
        let density = lerp(c0, c1, fx);
        let mut x = fx * lerp(c0, c1, 0.5 * fx) / (self.width - 1) as f32;
        if ix > 0 {
            x += at_p.blend(|s| {
                lerp(
                    self.cond_at(s, ix - 1, iy),
                    self.cond_at(s, ix - 1, iy + 1),
                    fy,
                )
            });
        }
        let rows = |y| at_p.blend(|s| self.row_total(s, y));
        let (r0, r1) = (rows(iy), rows(iy + 1));
        x /= lerp(r0, r1, fy);
        let mut y = fy * lerp(r0, r1, 0.5 * fy) / (self.height - 1) as f32;
        if iy > 0 {
            y += at_p.blend(|s| self.marg_at(s, iy - 1));
        }
        (Vec2::new(x, y), density)
    }

    /// The warp of the uniform point `u`: a point distributed by the
    /// table, and its density.
    fn sample(&self, u: Vec2, p: &[f32]) -> (Vec2, f32) {
        let at_p = self.corners(p);
        const EPS: f32 = 1.0 / (1u32 << 24) as f32;
        let (mut ux, mut uy) = (u.x.clamp(EPS, 1.0 - EPS), u.y.clamp(EPS, 1.0 - EPS));
        let (w, h) = (self.width, self.height);
        let marg = |y: usize| at_p.blend(|s| self.marg_at(s, y));
        let r = first_at_least(h - 1, uy, marg);
        if r > 0 {
            uy -= marg(r - 1);
        }
        let rows = |y| at_p.blend(|s| self.row_total(s, y));
        let (r0, r1) = (rows(r), rows(r + 1));
        let ty = segment(uy, h - 1, r0, r1);
        ux *= lerp(r0, r1, ty);
        let cond =
            |x: usize| at_p.blend(|s| lerp(self.cond_at(s, x, r), self.cond_at(s, x, r + 1), ty));
        let c = first_at_least(w - 1, ux, cond);
        if c > 0 {
            ux -= cond(c - 1);
        }
        let v = |x| at_p.blend(|s| lerp(self.at(s, x, r), self.at(s, x, r + 1), ty));
        let (c0, c1) = (v(c), v(c + 1));
        let tx = segment(ux, w - 1, c0, c1);
        (
            Vec2::new(
                (c as f32 + tx) / (w - 1) as f32,
                (r as f32 + ty) / (h - 1) as f32,
            ),
            lerp(c0, c1, tx),
        )
    }
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// The first index in [0, n) whose cumulative value `at` reaches `u`
/// (n − 1 if none), by bisection of the ascending values.
#[inline]
fn first_at_least(n: usize, u: f32, at: impl Fn(usize) -> f32) -> usize {
    let (mut lo, mut hi) = (0, n - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if at(mid) >= u {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

/// Where in a cell of width 1/`n`, its density linear from `a` to `b`,
/// the integral from the cell's start reaches `s` (a quadratic's root;
/// the mean slope where the two ends nearly agree).
#[inline]
fn segment(s: f32, n: usize, a: f32, b: f32) -> f32 {
    let s2 = 2.0 * n as f32 * s;
    let t = if (a - b).abs() > 1e-4 * (a + b) {
        (a - (a * a + s2 * (b - a)).max(0.0).sqrt()) / (a - b)
    } else if a + b != 0.0 {
        s2 / (a + b)
    } else {
        s2
    };
    t.clamp(0.0, 1.0)
}

/// The table's slices around a parameter point, and their weights: a
/// lookup reads each slice and blends.
struct Corners {
    slices: [usize; 8],
    weights: [f32; 8],
    n: usize,
}

impl Corners {
    /// Σ weight × `f(slice)`.
    #[inline]
    fn blend(&self, f: impl Fn(usize) -> f32) -> f32 {
        (0..self.n)
            .map(|k| self.weights[k] * f(self.slices[k]))
            .sum()
    }
}

/// A tensor file's element types.
#[derive(Clone, Copy, Debug, PartialEq)]
enum DType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F16,
    F32,
    F64,
}

impl DType {
    fn of(code: u8) -> Option<DType> {
        use DType::*;
        [U8, I8, U16, I16, U32, I32, U64, I64, F16, F32, F64]
            .get((code as usize).checked_sub(1)?)
            .copied()
    }

    fn size(self) -> usize {
        use DType::*;
        match self {
            U8 | I8 => 1,
            U16 | I16 | F16 => 2,
            U32 | I32 | F32 => 4,
            U64 | I64 | F64 => 8,
        }
    }
}

/// One field of a tensor file.
struct Field<'a> {
    name: String,
    dtype: DType,
    shape: Vec<usize>,
    bytes: &'a [u8],
}

impl Field<'_> {
    fn f32_values(&self) -> Vec<f32> {
        self.bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }
}

/// Mitsuba's tensor file (`.bsdf`): named, typed, shaped arrays.
struct TensorFile<'a> {
    fields: Vec<Field<'a>>,
}

impl<'a> TensorFile<'a> {
    fn parse(bytes: &'a [u8]) -> Result<Self, String> {
        const MAGIC: &[u8; 12] = b"tensor_file\0";
        if bytes.len() < 18 {
            return Err(format!(
                "{} bytes: too short for a tensor file (truncated?)",
                bytes.len()
            ));
        }
        if &bytes[..12] != MAGIC {
            return Err("not a tensor file (it does not start with \"tensor_file\")".into());
        }
        if bytes[13] != 0 {
            return Err(format!(
                "tensor file version {}.{} (only 1.0 is defined)",
                bytes[12], bytes[13]
            ));
        }
        let mut at = 14usize;
        let mut take = |n: usize| -> Result<&'a [u8], String> {
            let b = bytes
                .get(at..at.checked_add(n).ok_or("a field table past the end")?)
                .ok_or_else(|| {
                    "the field table ends past the end of the file (truncated?)".to_string()
                })?;
            at += n;
            Ok(b)
        };
        let count = u32::from_le_bytes(take(4)?.try_into().unwrap()) as usize;
        let mut fields = Vec::new();
        for _ in 0..count.min(1 << 16) {
            let len = u16::from_le_bytes(take(2)?.try_into().unwrap()) as usize;
            let name = String::from_utf8_lossy(take(len)?).into_owned();
            let rank = u16::from_le_bytes(take(2)?.try_into().unwrap()) as usize;
            let code = take(1)?[0];
            let dtype = DType::of(code)
                .ok_or_else(|| format!("field \"{name}\" has unknown type code {code}"))?;
            let offset = u64::from_le_bytes(take(8)?.try_into().unwrap());
            let mut shape = Vec::with_capacity(rank.min(8));
            for _ in 0..rank {
                shape.push(u64::from_le_bytes(take(8)?.try_into().unwrap()));
            }
            let size = shape
                .iter()
                .try_fold(dtype.size() as u64, |acc, &d| acc.checked_mul(d))
                .ok_or_else(|| format!("field \"{name}\" has an impossible shape {shape:?}"))?;
            let data = usize::try_from(offset)
                .ok()
                .zip(usize::try_from(size).ok())
                .and_then(|(o, s)| bytes.get(o..o.checked_add(s)?))
                .ok_or_else(|| {
                    format!(
                        "field \"{name}\" ({size} bytes at offset {offset}) lies past the end of \
                         the file ({} bytes; truncated?)",
                        bytes.len()
                    )
                })?;
            fields.push(Field {
                name,
                dtype,
                shape: shape.iter().map(|&d| d as usize).collect(),
                bytes: data,
            });
        }
        Ok(TensorFile { fields })
    }

    fn find(&self, name: &str) -> Option<&Field<'a>> {
        self.fields.iter().find(|f| f.name == name)
    }

    fn field(&self, name: &str) -> Result<&Field<'a>, String> {
        self.find(name)
            .ok_or_else(|| format!("the file has no field \"{name}\""))
    }
}

// Mitsuba's values are written with 9 digits, as printed.
#[allow(clippy::excessive_precision)]
#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::tests::Variant;
    use crate::bsdf::Material;

    /// (viewer ωi, light ωo, Mitsuba's eval, its pdf).
    type EvalCase = ([f32; 3], [f32; 3], [f32; 3], f32);
    /// (viewer ωi, sample2, Mitsuba's ωo, pdf, weight).
    type SampleCase = ([f32; 3], [f32; 2], [f32; 3], f32, [f32; 3]);

    include!("measured_refs.rs");

    const ISO: &[u8] = include_bytes!("../../../../scenes/parity/measured/ggx_iso.bsdf");
    const ANISO_R2: &[u8] = include_bytes!("../../../../scenes/parity/measured/ggx_aniso_r2.bsdf");
    const ANISO_R4: &[u8] = include_bytes!("../../../../scenes/parity/measured/ggx_aniso_r4.bsdf");

    fn lobe(bytes: &[u8]) -> MeasuredLobe {
        MeasuredLobe {
            data: MeasuredData::parse(bytes).unwrap().interned(),
        }
    }

    fn close(a: f32, b: f32, rel: f32) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-5
    }

    /// Values, densities and samples as Mitsuba 3.9.1's `measured` gives
    /// them for the same files: isotropic, and anisotropic folded by a
    /// half-turn and by mirrors.
    #[test]
    fn evaluates_and_samples_as_mitsuba() {
        let ctx = BsdfContext::default();
        type File = (
            &'static str,
            &'static [u8],
            &'static [EvalCase],
            &'static [SampleCase],
        );
        let files: [File; 3] = [
            ("iso", ISO, ISO_EVAL, ISO_SAMPLE),
            ("r2", ANISO_R2, R2_EVAL, R2_SAMPLE),
            ("r4", ANISO_R4, R4_EVAL, R4_SAMPLE),
        ];
        let mut failures = Vec::new();
        for (name, bytes, evals, samples) in files {
            let l = lobe(bytes);
            for &(wi, wo, f, pdf) in evals {
                let (v, view) = (Vec3::from(wo), Vec3::from(wi));
                let got = l.eval(&ctx, view, v);
                let got_pdf = l.pdf(&ctx, view, v);
                if !((0..3).all(|c| close(got[c], f[c], 1e-3)) && close(got_pdf, pdf, 1e-3)) {
                    failures.push(format!(
                        "{name} {wi:?} → {wo:?}: {got} / {got_pdf} vs {f:?} / {pdf}"
                    ));
                }
            }
            for &(wi, u, wo, pdf, weight) in samples {
                let s = l.sample(&ctx, Vec3::from(wi), 0.5, Vec2::from(u));
                let ok = s.is_some_and(|s| {
                    (s.wi - Vec3::from(wo)).length() < 1e-4
                        && close(s.pdf, pdf, 1e-3)
                        && (0..3).all(|c| close(s.weight[c], weight[c], 1e-3))
                });
                if !ok {
                    failures.push(format!(
                        "{name} sample {wi:?} {u:?}: {s:?} vs {wo:?} {pdf} {weight:?}"
                    ));
                }
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
        assert_eq!(ISO_EVAL.len() + R2_EVAL.len() + R4_EVAL.len(), 37 + 48);
    }

    /// The files in the table-driven test of every BSDF: sampling by
    /// chi-square, energy. Tabulated data is not exactly reciprocal.
    pub(crate) fn test_variants() -> Vec<Variant> {
        [
            ("iso", ISO),
            ("anisotropic, half-turn", ANISO_R2),
            ("anisotropic, mirrors", ANISO_R4),
        ]
        .into_iter()
        .map(|(name, bytes)| {
            let mut v = Variant::last(
                format!("measured (tabulated GGX, {name})"),
                vec![Material::Measured(Measured {
                    data: MeasuredData::parse(bytes).unwrap().interned(),
                })],
            );
            v.reciprocal = false;
            v
        })
        .collect()
    }

    /// Bad files: each refused with what is wrong.
    #[test]
    fn bad_files_are_refused() {
        let err = |b: &[u8]| MeasuredData::parse(b).err().unwrap();
        assert!(err(&ISO[..10]).contains("too short"), "{}", err(&ISO[..10]));
        assert!(err(&ISO[..40]).contains("truncated"), "{}", err(&ISO[..40]));
        assert!(err(&ISO[..ISO.len() - 100]).contains("past the end"));
        let mut magic = ISO.to_vec();
        magic[0] = b'T';
        assert!(err(&magic).contains("not a tensor file"));
        // Rename the field "rgb" to "xyz": missing.
        let mut renamed = ISO.to_vec();
        let at = renamed.windows(3).position(|w| w == b"rgb").unwrap();
        renamed[at..at + 3].copy_from_slice(b"xyz");
        assert!(
            err(&renamed).contains("no field \"rgb\""),
            "{}",
            err(&renamed)
        );
        // The vndf's first dimension (len(phi_i) = 1) changed to 2.
        let mut dims = ISO.to_vec();
        let name = dims.windows(4).position(|w| w == b"vndf").unwrap();
        let shape = name + 4 + 2 + 1 + 8;
        dims[shape..shape + 8].copy_from_slice(&2u64.to_le_bytes());
        let e = err(&dims);
        assert!(
            e.contains("vndf") && (e.contains("len(phi_i)") || e.contains("past the end")),
            "{e}"
        );
        let mut spectral = ISO.to_vec();
        spectral[at..at + 3].copy_from_slice(b"rgb");
        let desc = spectral
            .windows(11)
            .position(|w| w == b"description")
            .unwrap();
        spectral[desc..desc + 11].copy_from_slice(b"wavelengths");
        assert!(err(&spectral).contains("yubin renders in RGB"));
    }
}
