//! `envmap`: radiance arriving from infinitely far away, read from a
//! latitude–longitude image, and importance-sampled by the image's power.
//!
//! | parameter          | type      | default  | meaning                                         |
//! |--------------------|-----------|----------|-------------------------------------------------|
//! | `filename`         | string    | required | the image (EXR, HDR, PFM; 8-bit images are sRGB-decoded) |
//! | `scale`            | float     | 1        | factor on the image's radiance                  |
//! | `to_world`         | transform | identity | orientation of the map (its linear part)        |
//! | `mis_compensation` | boolean   | true     | sample from the map minus its mean (Karlík et al. 2019) where the integrator allows it (its own `mis_compensation`: `path`, `volpath`, and `direct` with BSDF samples) and the map is `visible_indirect`; false: the whole map always |
//!
//! ```xml
//! <emitter type="envmap">
//!     <string name="filename" value="textures/museum.exr"/>
//!     <transform name="to_world"><rotate y="1" angle="90"/></transform>
//! </emitter>
//! ```
//!
//! **The mapping** is Mitsuba 3's, checked against its `envmap` plugin's
//! `eval` (tests below): in the map's frame +y is up; the direction
//! `d = (sin θ sin φ, cos θ, −sin θ cos φ)` reads the image at
//! `u = φ / 2π`, `v = θ / π`, so the image's top row is +y, its left edge
//! −z and a quarter of the way across is +x. Horizontally, texels are
//! samples at their centres (`x = u·W − ½`) and wrap around; vertically,
//! the first and last rows are samples *at* the poles (`y = v·(H − 1)`).
//! Values between samples are bilinear. (Mitsuba's map with only two rows
//! differs from this; real maps have more.)
//!
//! **Sampling.** The bilinear radiance is a grid of W × (H − 1) patches
//! between sample points. Each patch gets the weight mean luminance of its
//! four corners × sin θ at its centre, approximating its power, and a
//! [`Distribution2D`] picks a point in (u, v) with density `p(u, v)`; as
//! dω = 2π² sin θ du dv, the density per solid angle is
//! `p(u, v) / (2π² sin θ)` (pbrt-v4 §12.5.2). With `mis_compensation`, a
//! patch's luminance is replaced by its excess over the map's mean
//! (clamped at 0) before weighting: with MIS, BSDF sampling then covers
//! the dim regions and light sampling spends its samples on the bright
//! ones (Karlík, Šik, Vévoda, Skřivan and Křivánek 2019, "MIS
//! Compensation: Optimizing Sampling Techniques in Multiple Importance
//! Sampling", ACM TOG 38(6)). That is right only where every light sample
//! is paired with a BSDF sample under MIS that can find the map, so it is
//! never done for other integrators (`ptracer`, `direct` without BSDF
//! samples) or for a map hidden from indirect rays.
//!
//! **Bad maps.** An image that is not twice as wide as tall (within 2 %)
//! is a load error, since it cannot be latitude–longitude; negative and
//! NaN or infinite texels are read as 0, with a warning that counts them.
//!
//! **Adding one to a scene**: `from_params` (or [`EnvMapLight::new`]) gives
//! an [`Emitter::EnvMap`](super::Emitter::EnvMap) that names its image in
//! [`Materials::images`](crate::material::Materials::images); pass it to
//! `SceneBuilder::add_emitter` like any other emitter. `SceneBuilder::build`
//! checks its image; a render's state (`render::RenderState`) builds its
//! sampling distribution, which depends on the integrator's MIS
//! compensation, and sets [`EnvMapLight::distribution`] in the render's
//! copy of the emitter.

use super::{latlong, EmitterContext, EmitterModel, EmitterSample};
use crate::params::{ParamError, Params};
use crate::sampling::{Distribution1D, Distribution2D};
use crate::spectrum::luminance;
use crate::texture::{TexImage, WrapMode};
use crate::Rgb;
use glam::{DMat3, DMat4, Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// An environment map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvMapLight {
    /// Index of the image in the scene's image table.
    pub image: u32,
    /// Index of its sampling distribution in the scene's light
    /// distributions (set when the scene is built).
    pub distribution: u32,
    /// Factor on the image's values.
    pub scale: f32,
    /// Sample the map minus its mean (see the module docs): `Some(false)`
    /// never; otherwise decided when the scene is built (where the
    /// integrator and the map's visibility allow it).
    pub mis_compensation: Option<bool>,
    /// World directions to the map's frame (the inverse of `to_world`'s
    /// linear part).
    pub light_from_world: Mat3,
    /// The map's frame to world directions.
    pub world_from_light: Mat3,
}

impl EnvMapLight {
    /// A map of image `image` oriented by `to_world` (its linear part; must
    /// be invertible), its distribution not yet built.
    pub fn new(image: u32, scale: f32, to_world: Mat3, mis_compensation: Option<bool>) -> Self {
        Self {
            image,
            distribution: u32::MAX,
            scale,
            mis_compensation,
            light_from_world: to_world.inverse(),
            world_from_light: to_world,
        }
    }

    /// From its scene parameters (table in the module docs).
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let image = p
            .image("filename")?
            .ok_or_else(|| p.error("needs a \"filename\""))?;
        let scale = p.float_or("scale", 1.0)?;
        if !scale.is_finite() {
            return Err(p.param_error("scale", &format!("must be finite, not {scale}")));
        }
        let m = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        // Directions only: the translation (and any projective part) is
        // irrelevant for a map at infinity.
        let linear = DMat3::from_mat4(m);
        let det = linear.determinant();
        if !det.is_finite() || det.abs() < 1e-12 {
            return Err(p.param_error("to_world", "must be invertible"));
        }
        let mis_compensation = p.boolean("mis_compensation")?;
        Ok(Self::new(image, scale, linear.as_mat3(), mis_compensation))
    }

    /// Checks that `img` can be a latitude–longitude map and makes its
    /// texels valid radiances: the width must be twice the height (within
    /// 2 %; cube maps and angular maps are not lat-long), and texels that
    /// are negative or not finite read as 0. Returns how many texels were
    /// set to 0, or why the image cannot be a map.
    pub fn prepare_image(img: &mut TexImage) -> Result<usize, String> {
        let (w, h) = (img.width, img.height);
        let aspect = w as f32 / h.max(1) as f32;
        if h < 2 || (aspect / 2.0 - 1.0).abs() > 0.02 {
            return Err(format!(
                "the image is {w}×{h}; a latitude–longitude environment map is twice as wide as it is tall (convert cube or angular maps first)"
            ));
        }
        let mut fixed = 0;
        if let crate::texture::image::ImageData::F32(data) = &mut img.data {
            for v in data.iter_mut() {
                if !(v.is_finite() && *v >= 0.0) {
                    *v = 0.0;
                    fixed += 1;
                }
            }
        }
        Ok(fixed)
    }

    /// Bilinear lookup at (u, v), unscaled (see the module docs for where
    /// the samples sit).
    #[inline]
    fn lookup(img: &TexImage, uv: Vec2) -> Rgb {
        let Bilinear { x, y, fx, fy } = Bilinear::at(img, uv);
        let t = |x, y| img.texel(x, y, true).truncate();
        (1.0 - fy) * ((1.0 - fx) * t(x[0], y[0]) + fx * t(x[1], y[0]))
            + fy * ((1.0 - fx) * t(x[0], y[1]) + fx * t(x[1], y[1]))
    }

    /// Asks the cache for the texels [`EnvMapLight::lookup`] will read at
    /// `uv`, so that their loads overlap the work before it.
    #[inline]
    fn prefetch_lookup(img: &TexImage, uv: Vec2) {
        let Bilinear { x, y, .. } = Bilinear::at(img, uv);
        img.prefetch(x[0], y[0]);
        img.prefetch(x[0], y[1]);
    }

    /// Radiance arriving along world direction `d` (unit length not
    /// required).
    #[inline]
    pub fn radiance(&self, ctx: &EmitterContext, d: Vec3) -> Rgb {
        let local = (self.light_from_world * d).normalize_or_zero();
        let img = &ctx.images[self.image as usize];
        Self::lookup(img, latlong::uv_of(local)) * self.scale
    }

    /// The sampling distribution over the patches between the samples of
    /// `img` (see the module docs). Its cell (c, r) is the patch from
    /// sample column c to c + 1 and row r to r + 1, so it starts half a
    /// texel to the right of u = c / W.
    pub fn sampling_distribution(&self, img: &TexImage) -> Distribution2D {
        use rayon::prelude::*;
        let (w, h) = (img.width as usize, img.height as usize);
        let rows = h.saturating_sub(1).max(1);
        // Row by row in parallel: a 4096 × 2048 map has 8 M texels.
        let mut lum = vec![0.0f32; w * h];
        let channels = img.channels as usize;
        lum.par_chunks_mut(w)
            .enumerate()
            .for_each(|(y, row)| match &img.data {
                // Float RGB(A) rows read straight from memory (the common HDR case).
                crate::texture::image::ImageData::F32(data) if channels >= 3 => {
                    let texels = &data[y * w * channels..(y + 1) * w * channels];
                    for (l, t) in row.iter_mut().zip(texels.chunks_exact(channels)) {
                        *l = luminance(Rgb::new(t[0], t[1], t[2]));
                    }
                }
                _ => {
                    for (x, l) in row.iter_mut().enumerate() {
                        *l = luminance(img.texel(x as u32, y as u32, true).truncate());
                    }
                }
            });
        let sin_theta = |r: usize| (PI * (r as f32 + 0.5) / rows as f32).sin();
        // Mean luminance of the patch from sample (c, r) to (c + 1, r + 1).
        let patch = |r: usize, c: usize| {
            let (r1, c1) = ((r + 1).min(h - 1), (c + 1) % w);
            0.25 * (lum[r * w + c] + lum[r * w + c1] + lum[r1 * w + c] + lum[r1 * w + c1])
        };
        let build = |offset: f32| -> Vec<Distribution1D> {
            (0..rows)
                .into_par_iter()
                .map(|r| {
                    let s = sin_theta(r);
                    let weights: Vec<f32> = (0..w)
                        .map(|c| (patch(r, c) - offset).max(0.0) * s)
                        .collect();
                    Distribution1D::from_vec(weights)
                })
                .collect()
        };
        if self.mis_compensation == Some(true) {
            let mean = mean_over_solid_angle(rows, w, patch, sin_theta);
            let compensated = build(mean as f32);
            // A map that is its mean everywhere has nothing left: keep it.
            if compensated.iter().any(|d| d.integral() > 0.0) {
                return Distribution2D::from_rows(compensated);
            }
        }
        Distribution2D::from_rows(build(0.0))
    }

    /// Radiance along world direction `wi` and the solid-angle density of
    /// sampling it.
    #[inline]
    pub fn radiance_and_pdf(&self, ctx: &EmitterContext, wi: Vec3) -> (Rgb, f32) {
        let img = &ctx.images[self.image as usize];
        let dist = &ctx.distributions[self.distribution as usize];
        let local = (self.light_from_world * wi).normalize_or_zero();
        let uv = latlong::uv_of(local);
        let radiance = Self::lookup(img, uv) * self.scale;
        let x = uv.x - Self::shift(img);
        let x = x - crate::math::floor(x);
        let pdf = latlong::solid_angle_pdf(dist.pdf(Vec2::new(x, uv.y)), local);
        (radiance, pdf)
    }

    /// The half-texel shift between image u and distribution x (see
    /// [`EnvMapLight::sampling_distribution`]).
    #[inline]
    fn shift(img: &TexImage) -> f32 {
        0.5 / img.width as f32
    }
}

/// The four samples around a point of the map and its place between them.
struct Bilinear {
    x: [u32; 2],
    y: [u32; 2],
    fx: f32,
    fy: f32,
}

impl Bilinear {
    #[inline]
    fn at(img: &TexImage, uv: Vec2) -> Self {
        let (w, h) = (img.width, img.height);
        let px = uv.x * w as f32 - 0.5;
        let fx0 = crate::math::floor(px);
        // Wrapped around in u.
        let x0 = WrapMode::Repeat.index(fx0 as i64, w);
        let x1 = if x0 + 1 == w { 0 } else { x0 + 1 };
        let py = uv.y * (h - 1) as f32;
        let y0 = (py.max(0.0) as u32).min(h.saturating_sub(2));
        Self {
            x: [x0, x1],
            y: [y0, (y0 + 1).min(h - 1)],
            fx: px - fx0,
            fy: (py - y0 as f32).clamp(0.0, 1.0),
        }
    }
}

impl EmitterModel for EnvMapLight {
    fn sample_direction(&self, ctx: &EmitterContext, _: Vec3, u: Vec2) -> Option<EmitterSample> {
        let img = &ctx.images[self.image as usize];
        let dist = &ctx.distributions[self.distribution as usize];
        let (p, pdf_uv) = dist.sample(u);
        let mut uv = Vec2::new(p.x + Self::shift(img), p.y);
        if uv.x >= 1.0 {
            uv.x -= 1.0;
        }
        if pdf_uv == 0.0 || uv.y <= 0.0 {
            return None;
        }
        Self::prefetch_lookup(img, uv);
        let (local, sin_theta) = latlong::direction_and_sin_theta(uv);
        let wi = (self.world_from_light * local).normalize();
        // Radiance and density at `uv` itself: a ray traced along `wi`
        // finds the same cell, except within round-off of its edges, where
        // its density may be the neighbour's (a set of directions too small
        // to matter, as in pbrt-v4). Going back from `wi` to its uv, as
        // `pdf_direction` must, would take two arctangents per light sample.
        let radiance = Self::lookup(img, uv) * self.scale;
        let pdf = pdf_uv / (2.0 * PI * PI * sin_theta);
        (pdf > 0.0 && pdf.is_finite()).then_some(EmitterSample {
            wi,
            dist: f32::INFINITY,
            pdf,
            radiance,
            is_delta: false,
        })
    }

    fn pdf_direction(&self, ctx: &EmitterContext, _: Vec3, _: Vec3, _: Vec3, wi: Vec3) -> f32 {
        self.radiance_and_pdf(ctx, wi).1
    }

    fn is_delta(&self) -> bool {
        false
    }
}

/// The mean of `patch(r, c)` (clamped at 0) over the sphere, rows `r`
/// weighted by `sin_theta(r)`, in f64. Rows are summed in parallel but
/// added in order: a parallel reduction adds them in an order that
/// depends on the thread count, and the image must not.
fn mean_over_solid_angle(
    rows: usize,
    w: usize,
    patch: impl Fn(usize, usize) -> f32 + Sync,
    sin_theta: impl Fn(usize) -> f32 + Sync,
) -> f64 {
    use rayon::prelude::*;
    let rows: Vec<(f64, f64)> = (0..rows)
        .into_par_iter()
        .map(|r| {
            let s = sin_theta(r) as f64;
            let row: f64 = (0..w).map(|c| patch(r, c).max(0.0) as f64).sum();
            (row * s, s * w as f64)
        })
        .collect();
    let (sum, area) = (rows.iter()).fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    sum / area
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::light::tests::Variant;
    use crate::light::{ConstantLight, Emitter};
    use crate::texture::image::ImageData;

    /// The 8 × 4 image the Mitsuba values below were computed on.
    fn mitsuba_test_image() -> TexImage {
        let (w, h) = (8, 4);
        let mut data = Vec::new();
        for y in 0..h {
            for x in 0..w {
                data.push(((x * 7 + y * 3) % 11) as f32 + 0.5);
                data.push(((x * 5 + y * 13) % 9) as f32 * 0.25 + 0.1);
                data.push((x * y) as f32 * 0.125 + 1.0);
            }
        }
        TexImage::new(w, h, 3, ImageData::F32(data), false).unwrap()
    }

    fn context<'a>(images: &'a [TexImage], dists: &'a [Distribution2D]) -> EmitterContext<'a> {
        EmitterContext {
            images,
            distributions: dists,
            ..EmitterContext::EMPTY
        }
    }

    #[test]
    fn the_compensation_mean_does_not_depend_on_the_thread_count() {
        // Values whose sums round differently when added in another order.
        let patch = |r: usize, c: usize| ((r * 131 + c * 71) % 997) as f32 * 1.37e-3 + 1e-7;
        let sin_theta = |r: usize| (PI * (r as f32 + 0.5) / 4096.0).sin();
        let in_pool = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build();
            pool.unwrap()
                .install(|| mean_over_solid_angle(4096, 8, patch, sin_theta).to_bits())
        };
        let one = in_pool(1);
        for threads in [2, 3, 5, 8] {
            assert_eq!(in_pool(threads), one, "{threads} threads");
        }
    }

    fn with_distribution(l: &mut EnvMapLight, img: &TexImage) -> Vec<Distribution2D> {
        l.distribution = 0;
        vec![l.sampling_distribution(img)]
    }

    /// Mitsuba 3.9.1 (`scalar_rgb`): the image above written with
    /// `mi.Bitmap(array).write("lit.exr")`, loaded as
    /// `{"type": "envmap", "filename": "lit.exr"}` (and, for the second
    /// table, with `"scale": 2.5` and `to_world` =
    /// `mi.ScalarTransform4f.rotate(normalize([1, 2, 3]), 37)`, whose
    /// linear part is `ROTATION` below, rows first), then
    /// `emitter.eval(si)` with `si.wi = -d`. The directions include both
    /// sides of the seam (u = 0 is −z), the seam itself, and both poles.
    const DIRECTIONS: [[f32; 3]; 10] = [
        [0.3030458, 0.5050762, -0.808122],
        [-0.009805336, 0.1961067, -0.9805336],
        [0.009805336, 0.1961067, -0.9805336],
        [0.0, 0.1961161, -0.9805807],
        [0.019997, 0.9997501, 0.0099985],
        [-0.0299865, -0.9993503, 0.019991],
        [1.0, 0.0, 0.0],
        [-0.4649906, -0.3487429, 0.8137335],
        [0.7929824, 0.1321637, 0.5947368],
        [-0.2721655, 0.9525794, -0.1360828],
    ];
    const MITSUBA_IDENTITY: [[f32; 3]; 10] = [
        [3.699175, 1.084138, 1.037587],
        [5.241256, 1.283327, 1.588396],
        [5.201192, 1.289693, 1.559175],
        [5.221247, 1.286501, 1.573782],
        [4.175173, 0.479928, 1.005579],
        [1.675906, 0.6224385, 2.761304],
        [7.25, 0.6625, 1.28125],
        [3.622543, 0.6931332, 1.95712],
        [6.342947, 0.8321931, 1.398178],
        [7.069992, 1.198164, 1.224777],
    ];
    const MITSUBA_ROTATED: [[f32; 3]; 10] = [
        [15.24173, 2.403379, 2.741107],
        [12.93213, 4.153146, 2.577085],
        [13.06487, 4.188384, 2.500665],
        [12.99721, 4.17077, 2.538991],
        [19.13303, 1.890889, 2.725655],
        [13.01433, 2.60729, 6.559424],
        [23.00256, 0.5123577, 3.741175],
        [16.42273, 2.581197, 4.524324],
        [13.12036, 2.159209, 3.875729],
        [13.40239, 1.693234, 2.567375],
    ];
    const ROTATION: [[f32; 3]; 3] = [
        [0.8130187, -0.4537591, 0.36483318],
        [0.5112918, 0.8561682, -0.074542746],
        [-0.2785341, 0.2471409, 0.92808414],
    ];

    #[test]
    fn radiance_matches_mitsuba_eval() {
        let images = [mitsuba_test_image()];
        let ctx = context(&images, &[]);
        let rotation = Mat3::from_cols_array_2d(&ROTATION).transpose();
        let cases = [
            (
                EnvMapLight::new(0, 1.0, Mat3::IDENTITY, Some(false)),
                MITSUBA_IDENTITY,
            ),
            (
                EnvMapLight::new(0, 2.5, rotation, Some(false)),
                MITSUBA_ROTATED,
            ),
        ];
        for (light, expected) in cases {
            for (d, want) in DIRECTIONS.iter().zip(expected) {
                let got = light.radiance(&ctx, Vec3::from_array(*d));
                let want = Vec3::from_array(want);
                assert!(
                    (got - want).abs().max_element() <= 2e-4 * want.max_element(),
                    "direction {d:?}: {got} but Mitsuba says {want}"
                );
            }
        }
    }

    /// An image that is dark except for a bright spot, and a sliver of
    /// colour across the seam.
    fn spot_image(w: u32, h: u32) -> TexImage {
        let mut data = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let v = if (x, y) == (w / 3, h / 4) {
                    [400.0, 300.0, 100.0]
                } else if x == 0 || x == w - 1 {
                    [0.0, 2.0, 5.0]
                } else {
                    [0.05, 0.05, 0.05 + 0.01 * y as f32]
                };
                data.extend_from_slice(&v);
            }
        }
        TexImage::new(w, h, 3, ImageData::F32(data), false).unwrap()
    }

    /// A dark map with one bright texel and a coloured seam, and the same
    /// rotated, scaled and with MIS compensation.
    pub(crate) fn test_variants() -> Vec<Variant> {
        let rotation = Mat3::from_cols_array_2d(&ROTATION).transpose();
        [
            (
                "envmap with a bright texel",
                EnvMapLight::new(0, 1.0, Mat3::IDENTITY, Some(false)),
                spot_image(24, 12),
            ),
            (
                "envmap rotated and compensated",
                EnvMapLight::new(0, 3.0, rotation, Some(true)),
                spot_image(17, 9),
            ),
        ]
        .into_iter()
        .map(|(name, light, image)| {
            let mut v = Variant::environment(name, Emitter::EnvMap(light));
            v.materials.images.push(image);
            v
        })
        .collect()
    }

    /// Sampling returns the radiance `radiance` gives in that direction,
    /// and the estimate of ∫ L dω from light samples is right (which it
    /// would not be if the distribution's cells and the image's patches
    /// were misaligned so that bright patches got no density).
    #[test]
    fn samples_carry_the_radiance_and_integrate_it() {
        let img = spot_image(24, 12);
        let mut light = EnvMapLight::new(0, 2.0, Mat3::from_rotation_x(0.4), Some(false));
        let dists = with_distribution(&mut light, &img);
        let images = [img];
        let ctx = context(&images, &dists);
        let mut rng = crate::sampler::Pcg32::new(5, 3);
        let n = 200_000;
        let mut estimate = 0.0f64;
        // Each sample beside what a ray along it finds (the sample is read
        // at its uv, the ray at the uv of its direction).
        let mut pairs = Vec::new();
        for _ in 0..n {
            let Some(s) = light.sample_direction(&ctx, Vec3::ZERO, rng.next_2d()) else {
                continue;
            };
            pairs.push((s, light.radiance_and_pdf(&ctx, s.wi)));
            estimate += (luminance(s.radiance) / s.pdf) as f64 / n as f64;
        }
        // The two uv agree to ~1e-6, which the spot's steep edges turn into
        // up to ~1e-4 of the peak radiance; only round-off at a cell's edge
        // puts the ray in the neighbouring cell, of another density.
        let peak = pairs
            .iter()
            .map(|(s, _)| s.radiance.max_element())
            .fold(0.0, f32::max);
        let mut other_density = 0;
        for (s, (radiance, pdf)) in &pairs {
            let off = (s.radiance - *radiance).abs().max_element();
            assert!(off <= 1e-4 * peak, "{} vs {radiance}", s.radiance);
            other_density += usize::from((s.pdf - pdf).abs() > 1e-5 * s.pdf.max(*pdf));
        }
        assert!(
            other_density <= n / 10_000,
            "{other_density} densities differ"
        );
        // Reference: a fine midpoint quadrature over the sphere.
        let (nt, np) = (600, 1200);
        let mut reference = 0.0f64;
        for i in 0..nt {
            let theta = (i as f32 + 0.5) / nt as f32 * PI;
            for j in 0..np {
                let phi = (j as f32 + 0.5) / np as f32 * 2.0 * PI;
                let d = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                reference += (luminance(light.radiance(&ctx, d)) * theta.sin()) as f64;
            }
        }
        reference *= (PI as f64 / nt as f64) * (2.0 * PI as f64 / np as f64);
        assert!(
            (estimate - reference).abs() < 0.01 * reference,
            "light-sampled {estimate}, quadrature {reference}"
        );
    }

    /// A map of one value everywhere is the `constant` emitter with that
    /// radiance.
    #[test]
    fn constant_image_is_the_constant_emitter() {
        let value = [0.7, 1.3, 2.1];
        let data = value.repeat(16 * 8);
        let img = TexImage::new(16, 8, 3, ImageData::F32(data), false).unwrap();
        let mut light = EnvMapLight::new(0, 1.5, Mat3::from_rotation_y(1.0), Some(false));
        let dists = with_distribution(&mut light, &img);
        let images = [img];
        let ctx = context(&images, &dists);
        let constant = Emitter::Constant(ConstantLight {
            radiance: Vec3::from_array(value) * 1.5,
        });
        let env = Emitter::EnvMap(light);
        assert!(env.is_environment());
        let mut rng = crate::sampler::Pcg32::new(9, 9);
        for _ in 0..1000 {
            let d = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            let a = env.environment_radiance(&ctx, d);
            let b = constant.environment_radiance(&ctx, d);
            assert!((a - b).abs().max_element() < 1e-5, "{a} vs {b} at {d}");
        }
    }

    /// Through the plugin table and the scene builder, as a front end
    /// does it: the image goes into the scene's table, the emitter from
    /// `PLUGINS` into `add_emitter`, and a render's state makes its
    /// distribution.
    #[test]
    fn envmap_through_the_plugin_table_and_scene_builder() {
        use crate::light::{EmitterModel, PLUGINS};
        use crate::render::{LightOptions, RenderScene, RenderState};
        use crate::scene::SceneBuilder;
        let rotation = Mat3::from_cols_array_2d(&ROTATION).transpose();
        use crate::testing::params::{MapParams, Value};
        // The front end would load the file; here it is image 0.
        let params = || {
            MapParams::new().float("scale", 2.5).with(
                "to_world",
                Value::Transform(DMat4::from_mat3(rotation.as_dmat3())),
            )
        };
        let (_, from_params) = PLUGINS.iter().find(|(name, _)| *name == "envmap").unwrap();
        let mut builder = SceneBuilder::new();
        assert_eq!(builder.add_image(mitsuba_test_image()), 0);
        let e = builder
            .add_emitter(from_params(&mut params().with("filename", Value::Image(0))).unwrap());
        let scene = builder.build().unwrap();
        assert_eq!(scene.environment_emitters, vec![e]);
        let state = RenderState::with_lights(&scene, LightOptions::default());
        assert_eq!(state.light_distributions().len(), 1);
        let render = RenderScene::new(&scene, &state);
        let ctx = render.emitter_context();
        let emitter = render.emitter(e);
        for (d, want) in DIRECTIONS.iter().zip(MITSUBA_ROTATED) {
            let got = emitter.environment_radiance(&ctx, Vec3::from_array(*d));
            let want = Vec3::from_array(want);
            assert!((got - want).abs().max_element() <= 2e-4 * want.max_element());
        }
        let s = emitter
            .sample_direction(&ctx, Vec3::ZERO, Vec2::new(0.3, 0.6))
            .unwrap();
        let pdf = emitter.pdf_direction(&ctx, Vec3::ZERO, Vec3::ZERO, Vec3::Z, s.wi);
        assert!((s.pdf - pdf).abs() < 1e-4 * pdf);

        assert!(from_params(&mut params()).is_err());
    }
}
