//! Eight vertices of a path packet shaded at once: the vertices whose BSDF
//! is a `diffuse` (alone or in `twosided`; a textured reflectance is
//! evaluated per vertex as it is queued), with
//! their light samples where the chosen light is an `area` light of
//! constant radiance on a `rectangle`. For them the light sample's point
//! (by area, or uniformly in the solid angle the rectangle subtends from
//! points near it), its density and direction, the BSDF's value and
//! density there, the MIS weight and the BSDF sample of the next
//! direction are computed in eight lanes instead of one vertex after
//! another, each a chain of dependent square roots and divisions. The
//! lanes are `fearless_simd`'s, the kernels compiled for each SIMD level
//! and chosen by the CPU at run time: one AVX register for the eight where
//! it has AVX2, two SSE registers on other x86-64 (`wide`, used elsewhere,
//! picks its form when the crate is built, so it would stay in SSE halves
//! in a portable build).
//!
//! Every lane does the operations the scalar code does, in the same
//! order, so a path comes out the same bit for bit whether it was shaded
//! here or alone (`packets_of_paths_equal_single_paths`,
//! `wide_light_samples_equal_single_ones`): the light sample as
//! [`crate::shape::Rectangle`]'s sampling (area sampling, and
//! [`SphericalRectangle`] with its f64 solid angle and
//! [`crate::math::sin_cos`]) and [`crate::light::AreaLight`] make it, the
//! BSDF as [`crate::bsdf::Diffuse`] and [`crate::bsdf::TwoSided`] evaluate
//! and sample it (Malley's method on the concentric map of
//! [`crate::sampling::square_to_cosine_hemisphere`]). Shadow rays, the
//! sampler's numbers and everything else stay per lane.

use crate::bsdf::Material;
use crate::interaction::SurfaceInteraction;
use crate::light::{Emitter, EmitterOptions};
use crate::material::Materials;
use crate::math::{
    Frame, ATAN_UNIT, COS_QUARTER, PIO2_HI, PIO2_LO, ROUND_TO_INTEGER, SIN_QUARTER, TAN_PI_8,
};
use crate::sampling::{
    RectangleFrame, SphericalRectangle, SPHERICAL_MAX_SOLID_ANGLE, SPHERICAL_MIN_SOLID_ANGLE,
};
use crate::shape::{NearZone, Shape};
use crate::texture::Tex;
use crate::Rgb;
use fearless_simd::{
    dispatch, f32x8, f64x8, mask32x8, mask64x8, Level, Select, Simd, SimdBase, SimdFloat, SimdFrom,
    SimdMask,
};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_2_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// Lanes of a batch.
pub(crate) const LANES: usize = 8;

/// The reflectances (constant or textured) of a `diffuse` BSDF, or of a
/// `twosided` one made of two of them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DiffuseSides {
    front: Tex,
    /// `None` for a one-sided `diffuse`, black from below.
    back: Option<Tex>,
}

impl DiffuseSides {
    /// The sides of `bsdf` when it is such a BSDF (a render keeps them
    /// per BSDF: [`WideTables`]).
    pub fn of(materials: &Materials, bsdf: &Material) -> Option<Self> {
        let reflectance = |b: &Material| match b {
            Material::Diffuse(d) => Some(d.reflectance),
            _ => None,
        };
        match bsdf {
            Material::TwoSided(t) => Some(Self {
                front: reflectance(&materials.bsdfs[t.front as usize])?,
                back: Some(reflectance(&materials.bsdfs[t.back as usize])?),
            }),
            b => Some(Self {
                front: reflectance(b)?,
                back: None,
            }),
        }
    }

    /// The reflectance seen from the local direction `wo` (a texture
    /// evaluated at `si`, as the scalar BSDF evaluates it), and −1 where
    /// that is the back side (the directions mirrored, as `twosided`
    /// does), 1 on the front; `None` where the BSDF reflects nothing: its
    /// values and samples all vanish (a one-sided `diffuse` from below).
    #[inline]
    pub fn facing(
        &self,
        materials: &Materials,
        si: &SurfaceInteraction,
        wo: Vec3,
    ) -> Option<(Rgb, f32)> {
        let (r, flip) = match self.back {
            // `twosided` takes wo.z ≥ 0 as its front (and NaN as its back).
            Some(back) if wo.z < 0.0 || wo.z.is_nan() => (back, -1.0),
            _ => (self.front, 1.0),
        };
        // `diffuse` sees wo mirrored by twosided, and gives nothing for
        // wo.z ≤ 0 there.
        if flip * wo.z <= 0.0 {
            None
        } else {
            Some((r.eval(materials, si), flip))
        }
    }
}

impl DiffuseSides {
    /// The BSDF's value and density towards the local direction `wi`, for
    /// the reflectance and side [`DiffuseSides::facing`] gave (whose `wo`
    /// lies above that side): what `diffuse`, behind `twosided`'s mirror
    /// on the back side, computes, bit for bit.
    #[inline]
    pub fn eval_pdf(reflectance: Rgb, flip: f32, wi: Vec3) -> (Rgb, f32) {
        let wi = Vec3::new(wi.x, wi.y, flip * wi.z);
        if wi.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        (
            reflectance * (FRAC_1_PI * wi.z),
            crate::sampling::cosine_hemisphere_pdf(wi),
        )
    }
}

/// An area light of constant radiance on a rectangle, as its area
/// sampling reads it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RectangleLight {
    /// The rectangle's placement: the unit square's images of x, y and
    /// its centre.
    x_axis: Vec3,
    y_axis: Vec3,
    z_axis: Vec3,
    translation: Vec3,
    normal: Vec3,
    inv_area: f32,
    radiance: Rgb,
    /// Whether the light sample is weighed by MIS against BSDF sampling.
    mis: bool,
    /// Where the rectangle is sampled by solid angle, and what that reads.
    near: NearZone,
}

impl RectangleLight {
    /// The emitter `emitter` (options `options`) when it is such a light
    /// (a render keeps them per emitter: [`WideTables`]).
    pub fn of(emitter: &Emitter, options: &EmitterOptions, shapes: &[Shape]) -> Option<Self> {
        let Emitter::Area(a) = emitter else {
            return None;
        };
        let Tex::Const(radiance) = a.radiance else {
            return None;
        };
        let Shape::Rectangle(r) = &shapes[a.shape as usize] else {
            return None;
        };
        let (m, normal, inv_area) = r.area_sampling();
        Some(Self {
            x_axis: m.matrix3.x_axis.into(),
            y_axis: m.matrix3.y_axis.into(),
            z_axis: m.matrix3.z_axis.into(),
            translation: m.translation.into(),
            normal,
            inv_area,
            radiance,
            mis: options.visible_indirect,
            near: r.near_zone(),
        })
    }

    /// The rectangle's frame for spherical sampling when `p` is near
    /// enough for that.
    #[inline]
    pub fn near_frame(&self, p: Vec3) -> Option<&RectangleFrame> {
        self.near.frame_at(p)
    }
}

/// What the wide shading reads of a scene, per BSDF and per emitter:
/// built once per render, held by its state
/// ([`crate::render::RenderState`]) and read through
/// [`crate::render::RenderScene::diffuse_sides_of`] and
/// [`crate::render::RenderScene::rectangle_light`].
#[derive(Clone, Debug, Default)]
pub(crate) struct WideTables {
    /// Per BSDF, its reflectances when it is a `diffuse` (alone or in
    /// `twosided`), which the path tracer shades eight at a time.
    diffuse_sides: Vec<Option<DiffuseSides>>,
    /// Per emitter, the rectangle light it is, if it is one of constant
    /// radiance, which the path tracer samples eight at a time.
    rectangle_lights: Vec<Option<RectangleLight>>,
}

impl WideTables {
    /// The tables of `scene`.
    pub fn new(scene: &crate::Scene) -> Self {
        let materials = &scene.materials;
        Self {
            diffuse_sides: (materials.bsdfs.iter())
                .map(|b| DiffuseSides::of(materials, b))
                .collect(),
            rectangle_lights: (scene.emitters.iter().zip(&scene.emitter_options))
                .map(|(e, o)| RectangleLight::of(e, o, &scene.shapes))
                .collect(),
        }
    }

    /// The sides of BSDF `bsdf` ([`DiffuseSides::of`]).
    #[inline]
    pub fn diffuse_sides(&self, bsdf: u32) -> Option<DiffuseSides> {
        self.diffuse_sides[bsdf as usize]
    }

    /// Emitter `emitter` as a rectangle light ([`RectangleLight::of`]).
    #[inline]
    pub fn rectangle_light(&self, emitter: u32) -> Option<&RectangleLight> {
        self.rectangle_lights[emitter as usize].as_ref()
    }
}

/// One lane's inputs.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DiffuseVertex<'a> {
    /// The hit point.
    pub p: Vec3,
    /// The shading frame.
    pub frame: Frame,
    /// The reflectance and side of [`DiffuseSides::facing`].
    pub reflectance: Rgb,
    pub flip: f32,
    /// The BSDF sample's numbers.
    pub u_bsdf: Vec2,
    /// The light to sample with its numbers and choice probability.
    pub light: Option<(&'a RectangleLight, Vec2, f32)>,
}

/// A light sample of a lane, before its shadow ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct UnshadowedLight {
    /// BSDF value times radiance (not zero).
    pub f_le: Rgb,
    /// MIS weight.
    pub w: f32,
    /// Light density (choice included).
    pub pdf: f32,
    /// Unit direction to the light sample, and its distance.
    pub wi: Vec3,
    pub dist: f32,
}

/// A lane's shading.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct DiffuseShading {
    /// The light sample, unless it contributes nothing.
    pub light: Option<UnshadowedLight>,
    /// The BSDF sample: world direction and density, unless it failed.
    pub bsdf: Option<(Vec3, f32)>,
}

/// Up to eight [`DiffuseVertex`]es, as lanes.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct DiffuseBatch {
    len: usize,
    p: [[f32; LANES]; 3],
    frame: [[f32; LANES]; 9],
    reflectance: [[f32; LANES]; 3],
    flip: [f32; LANES],
    u_bsdf: [[f32; LANES]; 2],
    /// 1 where the lane samples a light, 0 elsewhere.
    has_light: [f32; LANES],
    u_light: [[f32; LANES]; 2],
    pick_pdf: [f32; LANES],
    light_axes: [[f32; LANES]; 12],
    light_normal: [[f32; LANES]; 3],
    inv_area: [f32; LANES],
    radiance: [[f32; LANES]; 3],
    mis: [f32; LANES],
    /// The lanes whose light is sampled by solid angle (a bit each), and
    /// their rectangles' frames.
    near: u32,
    frames: [[f32; LANES]; FRAME_VALUES],
}

/// [`RectangleFrame`]'s values in lanes: corner, edges, unit edges and
/// normal (three each), edge lengths and their reciprocals.
const FRAME_VALUES: usize = 22;

/// Up to this many lanes sampled by solid angle are sampled one by one:
/// the eight-lane sampling costs about as much as that many single ones.
const FEW_NEAR: u32 = 2;

/// Eight lanes of `f32`, and their masks, for the SIMD level `S`.
type F8<S> = f32x8<S>;
type M8<S> = mask32x8<S>;

/// A 3-vector in eight lanes.
type V3<S> = [F8<S>; 3];

#[inline(always)]
fn dot<S: Simd>(a: &V3<S>, b: &V3<S>) -> F8<S> {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn lanes<S: Simd, const N: usize>(simd: S, a: &[[f32; LANES]; N]) -> [F8<S>; N] {
    a.map(
        #[inline(always)]
        |v| F8::simd_from(simd, v),
    )
}

/// The lanes of `a` that hold 1 (the others hold 0).
#[inline(always)]
fn ones<S: Simd>(simd: S, a: &[f32; LANES]) -> M8<S> {
    F8::simd_from(simd, *a).simd_eq(1.0)
}

/// Where `mask` holds, `a`, else `b`.
#[inline(always)]
fn select<S: Simd>(mask: M8<S>, a: F8<S>, b: F8<S>) -> F8<S> {
    mask.select(a, b)
}

/// `a < b ? b : a`, and `a` where `b` is NaN (as the scalar code's
/// `f32::max` takes it: the lanes are that bit for bit).
#[inline(always)]
fn max<S: Simd>(a: F8<S>, b: F8<S>) -> F8<S> {
    a.max_precise(b)
}

/// `a > b ? b : a`, and `a` where `b` is NaN (see [`max`]).
#[inline(always)]
fn min<S: Simd>(a: F8<S>, b: F8<S>) -> F8<S> {
    a.min_precise(b)
}

impl DiffuseBatch {
    /// Number of lanes filled.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Empties the batch.
    #[inline]
    pub fn clear(&mut self) {
        self.len = 0;
        self.near = 0;
    }
    /// Adds a lane.
    #[inline]
    pub fn push(&mut self, v: &DiffuseVertex<'_>) {
        let i = self.len;
        self.len += 1;
        for a in 0..3 {
            self.p[a][i] = v.p[a];
            self.frame[a][i] = v.frame.s[a];
            self.frame[3 + a][i] = v.frame.t[a];
            self.frame[6 + a][i] = v.frame.n[a];
            self.reflectance[a][i] = v.reflectance[a];
        }
        self.flip[i] = v.flip;
        self.u_bsdf[0][i] = v.u_bsdf.x;
        self.u_bsdf[1][i] = v.u_bsdf.y;
        let Some((l, u, pick_pdf)) = v.light else {
            self.has_light[i] = 0.0;
            return;
        };
        self.has_light[i] = 1.0;
        self.u_light[0][i] = u.x;
        self.u_light[1][i] = u.y;
        self.pick_pdf[i] = pick_pdf;
        for a in 0..3 {
            self.light_axes[a][i] = l.x_axis[a];
            self.light_axes[3 + a][i] = l.y_axis[a];
            self.light_axes[6 + a][i] = l.z_axis[a];
            self.light_axes[9 + a][i] = l.translation[a];
            self.light_normal[a][i] = l.normal[a];
            self.radiance[a][i] = l.radiance[a];
        }
        self.inv_area[i] = l.inv_area;
        self.mis[i] = if l.mis { 1.0 } else { 0.0 };
        if let Some(r) = l.near_frame(v.p) {
            self.near |= 1 << i;
            for (k, v) in [r.corner, r.ex, r.ey, r.x, r.y, r.z].iter().enumerate() {
                for a in 0..3 {
                    self.frames[3 * k + a][i] = v[a];
                }
            }
            for (k, v) in [r.w, r.l, r.inv_w, r.inv_l].into_iter().enumerate() {
                self.frames[18 + k][i] = v;
            }
        }
    }

    /// Shades every lane (`out[i]` for the i-th pushed), in AVX registers
    /// where the CPU has AVX2.
    pub fn shade(&self, out: &mut [DiffuseShading; LANES]) {
        self.shade_at(Level::new(), out);
    }

    /// [`DiffuseBatch::shade`] with the SIMD level `level` (or a lower
    /// one): in AVX registers at AVX2 and above, in SSE halves on other
    /// x86-64, lane by lane elsewhere; the same values bit for bit.
    pub(crate) fn shade_at(&self, level: Level, out: &mut [DiffuseShading; LANES]) {
        #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
        if let Some(avx2) = level.as_avx2() {
            return avx2.vectorize(
                #[inline(always)]
                || self.shade_lanes(avx2, out),
            );
        }
        dispatch!(level, simd => self.shade_lanes(simd, out))
    }

    #[inline(always)]
    fn shade_lanes<S: Simd>(&self, simd: S, out: &mut [DiffuseShading; LANES]) {
        let frame = lanes(simd, &self.frame);
        let s = [frame[0], frame[1], frame[2]];
        let t = [frame[3], frame[4], frame[5]];
        let n = [frame[6], frame[7], frame[8]];
        let p = lanes(simd, &self.p);
        let flip = F8::simd_from(simd, self.flip);
        let light = if self.has_light[..self.len].contains(&1.0) {
            self.light_samples(simd, &p, &n, flip)
        } else {
            [None; LANES]
        };
        let bsdf = self.bsdf_samples(simd, &s, &t, &n, flip);
        for (i, o) in out.iter_mut().enumerate().take(self.len) {
            o.light = light[i];
            o.bsdf = bsdf[i];
        }
    }

    /// The light samples, evaluated and weighed (as `sample_light`).
    #[inline(always)]
    fn light_samples<S: Simd>(
        &self,
        simd: S,
        p: &V3<S>,
        n: &V3<S>,
        flip: F8<S>,
    ) -> [Option<UnshadowedLight>; LANES] {
        let c = |v: f32| F8::splat(simd, v);
        let (zero, one) = (c(0.0), c(1.0));
        let axes = lanes(simd, &self.light_axes);
        let u = lanes(simd, &self.u_light);
        // The rectangle's area sample: the unit square's point
        // 2u − 1 placed by the rectangle's transform.
        let (lx, ly) = (c(2.0) * u[0] - one, c(2.0) * u[1] - one);
        let q: V3<S> = std::array::from_fn(
            #[inline(always)]
            |a| axes[a] * lx + axes[3 + a] * ly + axes[6 + a] * zero + axes[9 + a],
        );
        let ln = lanes(simd, &self.light_normal);
        // Its density per solid angle (`area_to_solid_angle`).
        let d: V3<S> = std::array::from_fn(
            #[inline(always)]
            |a| q[a] - p[a],
        );
        let dist2 = dot(&d, &d);
        let dist = dist2.sqrt();
        let n_dot_d = dot(&ln, &d).abs();
        let inv_area = F8::simd_from(simd, self.inv_area);
        let degenerate = n_dot_d.simd_le(c(1e-7) * dist) | dist2.simd_eq(zero);
        let pdf = select(degenerate, zero, inv_area * dist2 * dist / n_dot_d);
        // Nearer lanes sample the solid angle where it is in range.
        let (q, pdf) = match self.near.count_ones() {
            0 => (q, pdf),
            1..=FEW_NEAR => self.few_spherical_samples(simd, p, &u, q, pdf),
            _ => {
                let (q_near, pdf_near, in_range) = self.spherical_samples(simd, p, &u);
                let near = M8::from_bitmask(simd, u64::from(self.near)) & in_range;
                (
                    std::array::from_fn(
                        #[inline(always)]
                        |a| select(near, q_near[a], q[a]),
                    ),
                    select(near, pdf_near, pdf),
                )
            }
        };
        let d: V3<S> = std::array::from_fn(
            #[inline(always)]
            |a| q[a] - p[a],
        );
        let dist = dot(&d, &d).sqrt();
        // The area light's checks and direction (`emitted_towards`).
        let bad_pdf = pdf.is_nan() | pdf.simd_le(zero) | !pdf.is_finite();
        let inv_dist = one / dist;
        let wi: V3<S> = std::array::from_fn(
            #[inline(always)]
            |a| d[a] * inv_dist,
        );
        let behind = dot(&ln, &wi).simd_ge(zero);
        let valid = ones(simd, &self.has_light) & !bad_pdf & !dist.simd_eq(zero) & !behind;
        // The BSDF there (`diffuse` seen through `twosided`), which reads
        // only the shading frame's z of the direction.
        let wi_z = flip * dot(&wi, n);
        let lit = !wi_z.simd_le(zero);
        let cos_over_pi = c(FRAC_1_PI) * wi_z;
        let r = lanes(simd, &self.reflectance);
        let le = lanes(simd, &self.radiance);
        let f: V3<S> = std::array::from_fn(
            #[inline(always)]
            |a| select(lit, r[a] * cos_over_pi, zero),
        );
        let f_le: V3<S> = std::array::from_fn(
            #[inline(always)]
            |a| f[a] * le[a],
        );
        let f_nonzero = !(f[0].simd_eq(zero) & f[1].simd_eq(zero) & f[2].simd_eq(zero));
        let mis = ones(simd, &self.mis);
        let bsdf_pdf = select(lit & mis, max(wi_z, zero) * c(FRAC_1_PI), zero);
        let light_pdf = pdf * F8::simd_from(simd, self.pick_pdf);
        let w = select(mis, power_heuristic(simd, light_pdf * one, bsdf_pdf), one);
        let keep = (valid & f_nonzero).to_bitmask();
        std::array::from_fn(
            #[inline(always)]
            |i| {
                (keep >> i & 1 != 0).then(|| UnshadowedLight {
                    f_le: Vec3::new(f_le[0][i], f_le[1][i], f_le[2][i]),
                    w: w[i],
                    pdf: light_pdf[i],
                    wi: Vec3::new(wi[0][i], wi[1][i], wi[2][i]),
                    dist: dist[i],
                })
            },
        )
    }

    /// The points `q` and densities `pdf` of area sampling, with those of
    /// the few lanes sampled by solid angle replaced lane by lane
    /// ([`SphericalRectangle`], whose values [`Self::spherical_samples`]
    /// gives in lanes), where their solid angle is in range.
    #[inline(always)]
    fn few_spherical_samples<S: Simd>(
        &self,
        simd: S,
        o: &V3<S>,
        u: &[F8<S>; 2],
        q: V3<S>,
        pdf: F8<S>,
    ) -> (V3<S>, F8<S>) {
        let (mut q, mut pdf) = (
            q.map(
                #[inline(always)]
                |c| *c,
            ),
            *pdf,
        );
        for i in (0..LANES).filter(|i| self.near >> i & 1 != 0) {
            let f = |k: usize| self.frames[k][i];
            let v = |k: usize| Vec3::new(f(3 * k), f(3 * k + 1), f(3 * k + 2));
            let frame = RectangleFrame {
                corner: v(0),
                ex: v(1),
                ey: v(2),
                x: v(3),
                y: v(4),
                z: v(5),
                w: f(18),
                l: f(19),
                inv_w: f(20),
                inv_l: f(21),
            };
            let p = Vec3::new(o[0][i], o[1][i], o[2][i]);
            if let Some(sr) = SphericalRectangle::new(p, &frame) {
                let (point, _) = sr.sample(Vec2::new(u[0][i], u[1][i]));
                for a in 0..3 {
                    q[a][i] = point[a];
                }
                pdf[i] = 1.0 / sr.solid_angle();
            }
        }
        (
            q.map(
                #[inline(always)]
                |c| F8::simd_from(simd, c),
            ),
            F8::simd_from(simd, pdf),
        )
    }

    /// Points sampled uniformly in the solid angle the lanes' rectangles
    /// subtend from `o` (as [`crate::sampling::SphericalRectangle`]), their
    /// density, and where the solid angle is in the range that sampling
    /// takes.
    #[inline(always)]
    fn spherical_samples<S: Simd>(
        &self,
        simd: S,
        o: &V3<S>,
        u: &[F8<S>; 2],
    ) -> (V3<S>, F8<S>, M8<S>) {
        let c = |v: f32| F8::splat(simd, v);
        let one = c(1.0);
        let f = lanes(simd, &self.frames);
        let [corner, ex, ey, x, y, z]: [V3<S>; 6] = std::array::from_fn(
            #[inline(always)]
            |k| [f[3 * k], f[3 * k + 1], f[3 * k + 2]],
        );
        let (w, l, inv_w, inv_l) = (f[18], f[19], f[20], f[21]);
        // The rectangle in the frame at o (`LocalFrame`).
        let d: V3<S> = std::array::from_fn(
            #[inline(always)]
            |a| corner[a] - o[a],
        );
        let (x0, y0) = (dot(&d, &x), dot(&d, &y));
        let (x1, y1) = (x0 + w, y0 + l);
        let h = dot(&d, &z).abs();
        // Its corners' distances (`Corners`).
        let z0 = -h;
        let [xs, ys] = [[x0, x1, x1, x0], [y0, y0, y1, y1]];
        let len: [F8<S>; 4] = std::array::from_fn(
            #[inline(always)]
            |k| (xs[k] * xs[k] + ys[k] * ys[k] + z0 * z0).sqrt(),
        );
        let corners = [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]];
        let solid_angle = solid_angle(simd, &corners, &len);
        let in_range = solid_angle.simd_ge(c(SPHERICAL_MIN_SOLID_ANGLE))
            & solid_angle.simd_le(c(SPHERICAL_MAX_SOLID_ANGLE));
        // `SphericalRectangle::new`.
        let h2 = h * h;
        let (c2, s2) = (x0 * y1, h * len[3]);
        let (c3, s3) = (-x0 * y0, h * len[0]);
        let b0 = -y0 / (h2 + y0 * y0).sqrt();
        let b1 = y1 / (h2 + y1 * y1).sqrt();
        let norm = one / ((c2 * c2 + s2 * s2) * (c3 * c3 + s3 * s3)).sqrt();
        let cos_g = (c2 * c3 - s2 * s3) * norm;
        let sin_g = (s2 * c3 + c2 * s3) * norm;
        // `SphericalRectangle::sample`.
        let (sin_us, cos_us) = sin_cos(simd, u[0] * solid_angle);
        let sin_au = sin_us * cos_g - cos_us * sin_g;
        let cos_au = cos_us * cos_g + sin_us * sin_g;
        let fu = (cos_au * b0 - b1) / sin_au;
        let f2 = fu * fu + b0 * b0;
        let xu = h.copysign(fu) / max(f2 - one, c(1e-12)).sqrt();
        let xu = min(max(xu, x0), x1);
        let dist2 = xu * xu + h2;
        let h0 = y0 / (dist2 + y0 * y0).sqrt();
        let h1 = y1 / (dist2 + y1 * y1).sqrt();
        let hv = h0 + u[1] * (h1 - h0);
        let yv = hv * (dist2 / max(one - hv * hv, c(1e-12))).sqrt();
        let yv = min(max(yv, y0), y1);
        let (ux, uy) = (
            min(max((xu - x0) * inv_w, c(0.0)), one),
            min(max((yv - y0) * inv_l, c(0.0)), one),
        );
        let q = std::array::from_fn(
            #[inline(always)]
            |a| corner[a] + ux * ex[a] + uy * ey[a],
        );
        (q, one / solid_angle, in_range)
    }

    /// The BSDF samples: cosine-weighted directions, mirrored to the side
    /// the lane sees, in world space.
    #[inline(always)]
    fn bsdf_samples<S: Simd>(
        &self,
        simd: S,
        s: &V3<S>,
        t: &V3<S>,
        n: &V3<S>,
        flip: F8<S>,
    ) -> [Option<(Vec3, f32)>; LANES] {
        let c = |v: f32| F8::splat(simd, v);
        let (zero, one) = (c(0.0), c(1.0));
        let u = lanes(simd, &self.u_bsdf);
        // The concentric map (`concentric_with_radius`).
        let (ox, oy) = (c(2.0) * u[0] - one, c(2.0) * u[1] - one);
        let centre = ox.simd_eq(zero) & oy.simd_eq(zero);
        let around_x = ox.abs().simd_gt(oy.abs());
        let r = select(around_x, ox, oy);
        let across = select(around_x, oy, ox);
        let (sin, cos) = sin_cos_quarter(simd, c(FRAC_PI_4) * (across / r));
        let (cs, sn) = (select(around_x, cos, sin), select(around_x, sin, cos));
        let (dx, dy) = (select(centre, zero, r * cs), select(centre, zero, r * sn));
        let r = select(centre, zero, r);
        let z = max(one - r * r, zero).sqrt();
        let pdf = max(z, zero) * c(FRAC_1_PI);
        let z = flip * z;
        let wi: V3<S> = std::array::from_fn(
            #[inline(always)]
            |a| s[a] * dx + t[a] * dy + n[a] * z,
        );
        let ok = pdf.simd_gt(zero).to_bitmask();
        std::array::from_fn(
            #[inline(always)]
            |i| (ok >> i & 1 != 0).then(|| (Vec3::new(wi[0][i], wi[1][i], wi[2][i]), pdf[i])),
        )
    }
}

/// [`crate::sampling::power_heuristic`] lane by lane.
#[inline(always)]
fn power_heuristic<S: Simd>(simd: S, pdf_a: F8<S>, pdf_b: F8<S>) -> F8<S> {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    let zero = F8::splat(simd, 0.0);
    select(
        a.simd_eq(zero),
        zero,
        select(a.is_infinite(), F8::splat(simd, 1.0), a / (a + b)),
    )
}

/// The solid angle of the rectangle with corners `v` (distances `len`)
/// seen from the origin, as `Corners::solid_angle`: the two triangles'
/// Van Oosterom–Strackee half-angles summed as a product of complex
/// numbers in f64, and one arctangent.
#[inline(always)]
fn solid_angle<S: Simd>(simd: S, v: &[V3<S>; 4], len: &[F8<S>; 4]) -> F8<S> {
    let triple = v[0][2].abs() * (v[2][0] - v[0][0]) * (v[2][1] - v[0][1]);
    // (Functions rather than closures: a closure is not compiled for the
    // kernel's SIMD level when it is not inlined.)
    #[inline(always)]
    fn den<S: Simd>(v: &[V3<S>; 4], len: &[F8<S>; 4], [a, b, c]: [usize; 3]) -> F8<S> {
        len[a] * len[b] * len[c]
            + dot(&v[a], &v[b]) * len[c]
            + dot(&v[a], &v[c]) * len[b]
            + dot(&v[b], &v[c]) * len[a]
    }
    #[inline(always)]
    fn f64s<S: Simd>(simd: S, v: F8<S>) -> f64x8<S> {
        f64x8::simd_from(simd, (*v).map(f64::from))
    }
    let (t, d0, d1) = (
        f64s(simd, triple),
        f64s(simd, den(v, len, [0, 1, 2])),
        f64s(simd, den(v, len, [0, 2, 3])),
    );
    // `atan2_f64`'s ratio and octant.
    let (y, x) = (t * (d0 + d1), d0 * d1 - t * t);
    let (ax, ay) = (x.abs(), y.abs());
    let steep = ay.simd_gt(ax);
    let (lo, hi) = (steep.select(ax, ay), steep.select(ay, ax));
    let ratio = hi.simd_gt(0.0).select(lo / hi, f64x8::splat(simd, 0.0));
    let (steep, x_negative, y_negative) = (
        narrow(simd, steep),
        narrow(simd, x.simd_lt(0.0)),
        narrow(simd, y.simd_lt(0.0)),
    );
    let r = atan_unit(
        simd,
        F8::simd_from(
            simd,
            (*ratio).map(
                #[inline(always)]
                |v| v as f32,
            ),
        ),
    );
    let r = steep.select(F8::splat(simd, FRAC_PI_2) - r, r);
    let r = x_negative.select(F8::splat(simd, PI) - r, r);
    let r = y_negative.select(-r, r);
    F8::splat(simd, 2.0) * r
}

/// The f32 lanes' mask of an f64 lanes' mask.
#[inline(always)]
fn narrow<S: Simd>(simd: S, m: mask64x8<S>) -> M8<S> {
    M8::from_bitmask(simd, m.to_bitmask())
}

/// `atan_unit` (atan on [0, 1]) lane by lane.
#[inline(always)]
fn atan_unit<S: Simd>(simd: S, a: F8<S>) -> F8<S> {
    let c = |v: f32| F8::splat(simd, v);
    let reduce = a.simd_gt(c(TAN_PI_8));
    let t = reduce.select((a - c(1.0)) / (a + c(1.0)), a);
    let z = t * t;
    let [a0, a1, a2, a3] = ATAN_UNIT.map(c);
    let p = (((a0 * z - a1) * z + a2) * z - a3) * z * t + t;
    reduce.select(c(FRAC_PI_4) + p, p)
}

/// [`crate::math::sin_cos`] lane by lane.
#[inline(always)]
fn sin_cos<S: Simd>(simd: S, a: F8<S>) -> (F8<S>, F8<S>) {
    let c = |v: f32| F8::splat(simd, v);
    let k = (a * c(FRAC_2_PI) + c(ROUND_TO_INTEGER)) - c(ROUND_TO_INTEGER);
    let (s, co) = sin_cos_quarter(simd, (a - k * c(PIO2_HI)) - k * c(PIO2_LO));
    // k mod 4 (k a whole number): k − 4·round(k/4) is −2 … 2.
    let q = k - c(4.0) * ((k * c(0.25) + c(ROUND_TO_INTEGER)) - c(ROUND_TO_INTEGER));
    let (q1, q2, q3) = (
        q.simd_eq(1.0),
        q.simd_eq(2.0) | q.simd_eq(-2.0),
        q.simd_eq(-1.0),
    );
    let sin = q1.select(co, q2.select(-s, q3.select(-co, s)));
    let cos = q1.select(-s, q2.select(-co, q3.select(s, co)));
    (sin, cos)
}

/// [`crate::math::sin_cos_quarter`] lane by lane.
#[inline(always)]
fn sin_cos_quarter<S: Simd>(simd: S, a: F8<S>) -> (F8<S>, F8<S>) {
    let c = |v: f32| F8::splat(simd, v);
    let z = a * a;
    let ([s0, s1, s2], [c0, c1, c2]) = (SIN_QUARTER.map(c), COS_QUARTER.map(c));
    let sin = ((s0 * z + s1) * z - s2) * z * a + a;
    let cos = ((c0 * z - c1) * z + c2) * z * z - c(0.5) * z + c(1.0);
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::sample_chosen_light;
    use crate::light::LightChoice;
    use crate::math::Transform;
    use crate::render::{LightOptions, RenderScene, RenderState};
    use crate::sampler::Pcg32;
    use crate::shape::Rectangle;
    use crate::SceneBuilder;
    use glam::Affine3A;

    /// A rectangle light placed by `m`, alone in a scene.
    fn lit_by(m: Affine3A) -> crate::Scene {
        let mut b = SceneBuilder::new();
        let rectangle = Shape::Rectangle(Rectangle::new(Transform::new(m).unwrap(), false));
        b.add_shape(rectangle, None, Some(Rgb::new(3.0, 2.0, 1.0).into()))
            .unwrap();
        b.build().unwrap()
    }

    /// A lane's shading as bits (`None`s as empty).
    fn shading_bits(o: &DiffuseShading) -> Vec<u32> {
        let light = o.light.iter().flat_map(|l| {
            let [x, y, z] = l.wi.to_array();
            let [r, g, b] = l.f_le.to_array();
            [x, y, z, l.dist, l.pdf, l.w, r, g, b]
        });
        let bsdf = o.bsdf.iter().flat_map(|(wi, pdf)| {
            let [x, y, z] = wi.to_array();
            [x, y, z, *pdf]
        });
        light.chain(bsdf).map(f32::to_bits).collect()
    }

    /// Eight lanes' light samples are the scalar light samples bit for
    /// bit, by area and by solid angle, near lights and far, for lights
    /// square and sheared, with a frame facing the light (so that the
    /// diffuse BSDF keeps every sample the light gives), and the same at
    /// every SIMD level.
    #[test]
    fn wide_light_samples_equal_single_ones() {
        let lights = [
            Affine3A::from_translation(Vec3::new(0.0, 2.0, 0.0)) * Affine3A::from_rotation_x(1.57),
            Affine3A::from_translation(Vec3::new(0.3, 1.0, -0.2))
                * Affine3A::from_rotation_x(2.0)
                * Affine3A::from_scale(Vec3::new(3.0, 0.4, 1.0)),
            // Sheared: sampled by area from everywhere.
            Affine3A::from_rotation_x(1.0)
                * Affine3A::from_cols_array(&[
                    1.0, 0.0, 0.0, 0.6, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
                ]),
        ];
        let mut rng = Pcg32::new(7, 1);
        let (mut near, mut far, mut kept) = (0, 0, 0);
        for m in lights {
            let scene = lit_by(m);
            let state = RenderState::with_lights(&scene, LightOptions::default());
            let scene = RenderScene::new(&scene, &state);
            let light = scene.rectangle_light(0).copied().unwrap();
            let choice = LightChoice {
                emitter: 0,
                prim: LightChoice::WHOLE,
            };
            let centre = m.transform_point3(Vec3::ZERO);
            for _ in 0..400 {
                let mut batch = DiffuseBatch::default();
                let mut cases = Vec::new();
                for _ in 0..LANES {
                    let r = 0.05 + 6.0 * rng.next_f32().powi(2);
                    let dir = crate::sampling::square_to_uniform_sphere(rng.next_2d());
                    let p = centre + r * dir;
                    let u = rng.next_2d();
                    let facing = (centre - p).normalize();
                    if light.near_frame(p).is_some() {
                        near += 1;
                    } else {
                        far += 1;
                    }
                    batch.push(&DiffuseVertex {
                        p,
                        frame: Frame::from_normal(facing),
                        reflectance: Rgb::ONE,
                        flip: 1.0,
                        u_bsdf: Vec2::splat(0.3),
                        light: Some((&light, u, 1.0)),
                    });
                    cases.push((p, u));
                }
                // Every SIMD level this CPU runs: SSE halves and AVX (when
                // it has AVX2).
                let mut out = [[DiffuseShading::default(); LANES]; 2];
                batch.shade_at(Level::baseline(), &mut out[0]);
                batch.shade_at(Level::new(), &mut out[1]);
                for ((p, u), (o, o_new)) in cases.into_iter().zip(out[0].into_iter().zip(out[1])) {
                    assert_eq!(shading_bits(&o), shading_bits(&o_new), "{p} {u}");
                    let single = sample_chosen_light(&scene, choice, p, u)
                        .filter(|ls| ls.wi.dot((centre - p).normalize()) > 0.0);
                    let wide = o.light.map(|l| (l.wi, l.dist, l.pdf));
                    let single = single.map(|ls| (ls.wi, ls.dist, ls.pdf));
                    let bits = |v: Option<(Vec3, f32, f32)>| {
                        v.map(|(w, d, p)| {
                            (w.to_array().map(f32::to_bits), d.to_bits(), p.to_bits())
                        })
                    };
                    assert_eq!(bits(wide), bits(single), "{p} {u}");
                    kept += usize::from(wide.is_some());
                }
            }
        }
        assert!(
            near > 1000 && far > 1000 && kept > 3000,
            "{near} {far} {kept}"
        );
    }
}
