//! Eight vertices of a path packet shaded at once: the vertices whose BSDF
//! is a `diffuse` of constant reflectance (alone or in `twosided`), with
//! their light samples where the chosen light is an `area` light of
//! constant radiance on a `rectangle` sampled by area. For them the light
//! sample's point, its density and direction, the BSDF's value and density
//! there, the MIS weight and the BSDF sample of the next direction are
//! computed in eight lanes (`wide::f32x8`) instead of one vertex after
//! another, each a chain of dependent square roots and divisions.
//!
//! Every lane does the operations the scalar code does, in the same
//! order, so a path comes out the same bit for bit whether it was shaded
//! here or alone ([`super::PathIntegrator`]'s packet test): the light
//! sample as [`crate::shape::Rectangle`]'s area sampling and
//! [`crate::light::AreaLight`] make it, the BSDF as
//! [`crate::bsdf::Diffuse`] and [`crate::bsdf::TwoSided`] evaluate and
//! sample it (Malley's method on the concentric map of
//! [`crate::sampling::square_to_cosine_hemisphere`]). Shadow rays, the
//! sampler's numbers and everything else stay per lane.

use crate::bsdf::Bsdf;
use crate::light::{Emitter, EmitterOptions, LightChoice};
use crate::material::Materials;
use crate::math::Frame;
use crate::shape::{NearZone, Shape};
use crate::texture::Tex;
use crate::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};
use wide::{f32x8, CmpEq, CmpGe, CmpGt, CmpLe};

/// Lanes of a batch.
pub(crate) const LANES: usize = 8;

/// The reflectances of a `diffuse` BSDF of constant reflectance, or of a
/// `twosided` one made of two of them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DiffuseSides {
    front: Rgb,
    /// `None` for a one-sided `diffuse`, black from below.
    back: Option<Rgb>,
}

impl DiffuseSides {
    /// The sides of `bsdf` when it is such a BSDF (the scene keeps them
    /// per BSDF: [`crate::Scene::diffuse_sides_of`]).
    pub fn of(materials: &Materials, bsdf: &Bsdf) -> Option<Self> {
        let constant = |b: &Bsdf| match b {
            Bsdf::Diffuse(d) => match d.reflectance {
                Tex::Const(c) => Some(c),
                Tex::Texture(_) => None,
            },
            _ => None,
        };
        match bsdf {
            Bsdf::TwoSided(t) => Some(Self {
                front: constant(&materials.bsdfs[t.front as usize])?,
                back: Some(constant(&materials.bsdfs[t.back as usize])?),
            }),
            b => Some(Self {
                front: constant(b)?,
                back: None,
            }),
        }
    }

    /// The reflectance seen from the local direction `wo`, and −1 where
    /// that is the back side (the directions mirrored, as `twosided`
    /// does), 1 on the front; `None` where the BSDF reflects nothing: its
    /// values and samples all vanish (a one-sided `diffuse` from below).
    #[inline]
    pub fn facing(&self, wo: Vec3) -> Option<(Rgb, f32)> {
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
            Some((r, flip))
        }
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
    /// Where the rectangle is sampled by solid angle instead (not here).
    near: NearZone,
}

impl RectangleLight {
    /// The emitter `emitter` (options `options`) when it is such a light
    /// (the scene keeps them per emitter: [`crate::Scene::rectangle_light`]).
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

    /// Whether the light, chosen whole, is sampled by area from `p`.
    #[inline]
    pub fn sampled_by_area_from(&self, light: LightChoice, p: Vec3) -> bool {
        light.prim == LightChoice::WHOLE && !self.near.contains(p)
    }
}

/// One lane's inputs.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DiffuseVertex {
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
    pub light: Option<(RectangleLight, Vec2, f32)>,
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
}

/// A 3-vector in eight lanes.
type V3 = [f32x8; 3];

#[inline]
fn dot(a: &V3, b: &V3) -> f32x8 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn lanes<const N: usize>(a: &[[f32; LANES]; N]) -> [f32x8; N] {
    a.map(f32x8::new)
}

/// Where `mask` holds, `a`, else `b`.
#[inline]
fn select(mask: f32x8, a: f32x8, b: f32x8) -> f32x8 {
    mask.blend(a, b)
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
    }

    /// The reflectance of lane `i`.
    #[inline]
    pub fn reflectance(&self, i: usize) -> Rgb {
        Vec3::new(
            self.reflectance[0][i],
            self.reflectance[1][i],
            self.reflectance[2][i],
        )
    }

    /// Adds a lane.
    #[inline]
    pub fn push(&mut self, v: &DiffuseVertex) {
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
    }

    /// Shades every lane (`out[i]` for the i-th pushed).
    #[inline(never)]
    pub fn shade(&self, out: &mut [DiffuseShading; LANES]) {
        let frame = lanes(&self.frame);
        let s = [frame[0], frame[1], frame[2]];
        let t = [frame[3], frame[4], frame[5]];
        let n = [frame[6], frame[7], frame[8]];
        let p = lanes(&self.p);
        let flip = f32x8::new(self.flip);
        let light = self.light_samples(&p, &n, flip);
        let bsdf = self.bsdf_samples(&s, &t, &n, flip);
        for (i, o) in out.iter_mut().enumerate().take(self.len) {
            o.light = light[i];
            o.bsdf = bsdf[i];
        }
    }

    /// The light samples, evaluated and weighed (as `sample_light`).
    #[inline]
    fn light_samples(&self, p: &V3, n: &V3, flip: f32x8) -> [Option<UnshadowedLight>; LANES] {
        let zero = f32x8::ZERO;
        let one = f32x8::ONE;
        let axes = lanes(&self.light_axes);
        let u = lanes(&self.u_light);
        // The rectangle's area sample: the unit square's point
        // 2u − 1 placed by the rectangle's transform.
        let (lx, ly) = (
            f32x8::splat(2.0) * u[0] - one,
            f32x8::splat(2.0) * u[1] - one,
        );
        let q: V3 = std::array::from_fn(|a| {
            axes[a] * lx + axes[3 + a] * ly + axes[6 + a] * zero + axes[9 + a]
        });
        let ln = lanes(&self.light_normal);
        // Its density per solid angle (`area_to_solid_angle`).
        let d: V3 = std::array::from_fn(|a| q[a] - p[a]);
        let dist2 = dot(&d, &d);
        let dist = dist2.sqrt();
        let n_dot_d = dot(&ln, &d).abs();
        let inv_area = f32x8::new(self.inv_area);
        let degenerate = n_dot_d.cmp_le(f32x8::splat(1e-7) * dist) | dist2.cmp_eq(zero);
        let pdf = select(degenerate, zero, inv_area * dist2 * dist / n_dot_d);
        // The area light's checks and direction (`emitted_towards`).
        let bad_pdf = pdf.is_nan() | pdf.cmp_le(zero) | !pdf.is_finite();
        let inv_dist = one / dist;
        let wi: V3 = std::array::from_fn(|a| d[a] * inv_dist);
        let behind = dot(&ln, &wi).cmp_ge(zero);
        let valid =
            f32x8::new(self.has_light).cmp_eq(one) & !bad_pdf & !dist.cmp_eq(zero) & !behind;
        // The BSDF there (`diffuse` seen through `twosided`), which reads
        // only the shading frame's z of the direction.
        let wi_z = flip * dot(&wi, n);
        let lit = !wi_z.cmp_le(zero);
        let cos_over_pi = f32x8::splat(FRAC_1_PI) * wi_z;
        let r = lanes(&self.reflectance);
        let le = lanes(&self.radiance);
        let f_le: V3 = std::array::from_fn(|a| select(lit, r[a] * cos_over_pi, zero) * le[a]);
        let f_nonzero = !(select(lit, r[0] * cos_over_pi, zero).cmp_eq(zero)
            & select(lit, r[1] * cos_over_pi, zero).cmp_eq(zero)
            & select(lit, r[2] * cos_over_pi, zero).cmp_eq(zero));
        let mis = f32x8::new(self.mis).cmp_eq(one);
        let bsdf_pdf = select(lit & mis, wi_z.max(zero) * f32x8::splat(FRAC_1_PI), zero);
        let light_pdf = pdf * f32x8::new(self.pick_pdf);
        let w = select(mis, power_heuristic(light_pdf * one, bsdf_pdf), one);
        let keep = (valid & f_nonzero).to_array();
        let (f_le, w, light_pdf, wi, dist) = (
            f_le.map(|c| c.to_array()),
            w.to_array(),
            light_pdf.to_array(),
            wi.map(|c| c.to_array()),
            dist.to_array(),
        );
        std::array::from_fn(|i| {
            (keep[i] != 0.0).then(|| UnshadowedLight {
                f_le: Vec3::new(f_le[0][i], f_le[1][i], f_le[2][i]),
                w: w[i],
                pdf: light_pdf[i],
                wi: Vec3::new(wi[0][i], wi[1][i], wi[2][i]),
                dist: dist[i],
            })
        })
    }

    /// The BSDF samples: cosine-weighted directions, mirrored to the side
    /// the lane sees, in world space.
    #[inline]
    fn bsdf_samples(&self, s: &V3, t: &V3, n: &V3, flip: f32x8) -> [Option<(Vec3, f32)>; LANES] {
        let zero = f32x8::ZERO;
        let one = f32x8::ONE;
        let u = lanes(&self.u_bsdf);
        // The concentric map (`concentric_with_radius`).
        let (ox, oy) = (
            f32x8::splat(2.0) * u[0] - one,
            f32x8::splat(2.0) * u[1] - one,
        );
        let centre = ox.cmp_eq(zero) & oy.cmp_eq(zero);
        let around_x = ox.abs().cmp_gt(oy.abs());
        let r = select(around_x, ox, oy);
        let across = select(around_x, oy, ox);
        let (sin, cos) = sin_cos_quarter(f32x8::splat(FRAC_PI_4) * (across / r));
        let (c, sn) = (select(around_x, cos, sin), select(around_x, sin, cos));
        let (dx, dy) = (select(centre, zero, r * c), select(centre, zero, r * sn));
        let r = select(centre, zero, r);
        let z = (one - r * r).max(zero).sqrt();
        let pdf = z.max(zero) * f32x8::splat(FRAC_1_PI);
        let z = flip * z;
        let wi: V3 = std::array::from_fn(|a| s[a] * dx + t[a] * dy + n[a] * z);
        let ok = pdf.cmp_gt(zero).to_array();
        let (wi, pdf) = (wi.map(|c| c.to_array()), pdf.to_array());
        std::array::from_fn(|i| {
            (ok[i] != 0.0).then(|| (Vec3::new(wi[0][i], wi[1][i], wi[2][i]), pdf[i]))
        })
    }
}

/// [`crate::sampling::power_heuristic`] lane by lane.
#[inline]
fn power_heuristic(pdf_a: f32x8, pdf_b: f32x8) -> f32x8 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    let zero = f32x8::ZERO;
    select(
        a.cmp_eq(zero),
        zero,
        select(a.is_inf(), f32x8::ONE, a / (a + b)),
    )
}

/// [`crate::math::sin_cos_quarter`] lane by lane.
#[inline]
fn sin_cos_quarter(a: f32x8) -> (f32x8, f32x8) {
    let c = f32x8::splat;
    let z = a * a;
    let sin = ((c(-1.951_529_6e-4) * z + c(8.332_161e-3)) * z - c(1.666_665_5e-1)) * z * a + a;
    let cos = ((c(2.443_315_7e-5) * z - c(1.388_731_6e-3)) * z + c(4.166_664_6e-2)) * z * z
        - c(0.5) * z
        + c(1.0);
    (sin, cos)
}
