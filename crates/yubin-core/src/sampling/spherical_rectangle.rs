//! Uniform sampling of the solid angle a rectangle subtends from a point,
//! by the area-preserving parametrization of spherical rectangles of
//! Ureña, Fajardo and King, "An Area-Preserving Parametrization for
//! Spherical Rectangles" (EGSR 2013): the first coordinate picks, by
//! solid angle, the line x = const of the rectangle; the second places
//! the point on it uniformly in the sine of its elevation. Every sample
//! has the density 1/Ω, which removes the 1/r² and cos θ variation of
//! area sampling near a large light.
//!
//! Ω itself is computed by Van Oosterom and Strackee's formula for the
//! two triangles of the rectangle ("The Solid Angle of a Plane
//! Triangle", IEEE Trans. Biomed. Eng. 30(2), 1983), whose triple
//! product is exact here (h·w·l): the sum of the corner angles minus 2π
//! would lose digits for far lights.

use super::{
    SPHERICAL_MAX_SOLID_ANGLE as MAX_SOLID_ANGLE, SPHERICAL_MIN_SOLID_ANGLE as MIN_SOLID_ANGLE,
};
use crate::math::atan2_f64;
use glam::{Vec2, Vec3};
use wide::f32x4;

/// A rectangle as seen from a point, ready to be sampled.
#[derive(Clone, Copy, Debug)]
pub struct SphericalRectangle {
    /// The rectangle: a corner and its two edges.
    corner: Vec3,
    ex: Vec3,
    ey: Vec3,
    /// The edges' reciprocal lengths.
    inv_w: f32,
    inv_l: f32,
    /// The rectangle in a frame at the point with axes along the edges and
    /// the normal: [x0, x1] × [y0, y1] at the distance h ≥ 0.
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    h: f32,
    /// z components of the normals of the planes through the point and
    /// the edges y = y0 and y = y1.
    b0: f32,
    b1: f32,
    /// Cosine and sine of the sum of the corner angles at (x0, y0) and
    /// (x0, y1): the solid angle swept from the edge x = x0 starts at 2π
    /// minus it.
    cos_g: f32,
    sin_g: f32,
    /// The solid angle.
    solid_angle: f32,
}

/// What of a rectangle the spherical sampling reads that does not depend
/// on the point it is seen from: its corner and edges, their lengths and
/// unit directions. Kept by the shape, since each sample would otherwise
/// take two square roots and two divisions more, on the divider that the
/// sample's own dozen divisions and square roots keep busy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RectangleFrame {
    pub(crate) corner: Vec3,
    pub(crate) ex: Vec3,
    pub(crate) ey: Vec3,
    /// Unit `ex` and `ey`, and their cross product.
    pub(crate) x: Vec3,
    pub(crate) y: Vec3,
    pub(crate) z: Vec3,
    /// The edges' lengths and their reciprocals.
    pub(crate) w: f32,
    pub(crate) l: f32,
    pub(crate) inv_w: f32,
    pub(crate) inv_l: f32,
}

impl RectangleFrame {
    /// The rectangle with corner `corner` and perpendicular edges `ex`,
    /// `ey`.
    pub fn new(corner: Vec3, ex: Vec3, ey: Vec3) -> Self {
        let (w, l) = (ex.length(), ey.length());
        let (inv_w, inv_l) = (1.0 / w, 1.0 / l);
        let (x, y) = (ex * inv_w, ey * inv_l);
        Self {
            corner,
            ex,
            ey,
            x,
            y,
            z: x.cross(y),
            w,
            l,
            inv_w,
            inv_l,
        }
    }
}

impl SphericalRectangle {
    /// The rectangle `r` as seen from `o`; `None` when its solid angle
    /// lies outside
    /// [`SPHERICAL_MIN_SOLID_ANGLE`](super::SPHERICAL_MIN_SOLID_ANGLE), [`SPHERICAL_MAX_SOLID_ANGLE`](super::SPHERICAL_MAX_SOLID_ANGLE) (then sample by area).
    #[inline]
    pub fn new(o: Vec3, r: &RectangleFrame) -> Option<Self> {
        let f = LocalFrame::new(o, r);
        let (corner, ex, ey) = (r.corner, r.ex, r.ey);
        let corners = Corners::new(&f);
        let solid_angle = corners.solid_angle();
        if !(MIN_SOLID_ANGLE..=MAX_SOLID_ANGLE).contains(&solid_angle) {
            return None;
        }
        let (x0, y0, y1, h) = (f.x0, f.y0, f.y1, f.h);
        let h2 = h * h;
        // The corner angles of the spherical rectangle at (x0, y1) and
        // (x0, y0), between the planes through o and the two edges meeting
        // there, as unnormalized (cosine, sine) pairs; their sum's.
        let (c2, s2) = (x0 * y1, h * corners.len[3]);
        let (c3, s3) = (-x0 * y0, h * corners.len[0]);
        // b0, b1 and the pair's normalization in three lanes: one square
        // root and one division for the three (see `sample`).
        let [b0, b1, norm, _] = (f32x4::new([-y0, y1, 1.0, 1.0])
            / f32x4::new([
                h2 + y0 * y0,
                h2 + y1 * y1,
                (c2 * c2 + s2 * s2) * (c3 * c3 + s3 * s3),
                1.0,
            ])
            .sqrt())
        .to_array();
        Some(Self {
            corner,
            ex,
            ey,
            inv_w: f.inv_w,
            inv_l: f.inv_l,
            x0,
            x1: f.x1,
            y0,
            y1,
            h,
            b0,
            b1,
            cos_g: (c2 * c3 - s2 * s3) * norm,
            sin_g: (s2 * c3 + c2 * s3) * norm,
            solid_angle,
        })
    }

    /// The solid angle the rectangle subtends (sr).
    #[inline]
    pub fn solid_angle(&self) -> f32 {
        self.solid_angle
    }

    /// A point on the rectangle, uniform in solid angle from `o`, with its
    /// coordinates in [0, 1]² along the two edges.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec2) {
        let h2 = self.h * self.h;
        // The line x = xu whose strip [x0, xu] subtends u.x of the angle
        // (Ureña et al.'s cu = 1/√(fu² + b0²), folded into xu).
        // au = u.x Ω + 2π − g, by the angle-sum rules.
        let (sin_us, cos_us) = crate::math::sin_cos(u.x * self.solid_angle);
        let sin_au = sin_us * self.cos_g - cos_us * self.sin_g;
        let cos_au = cos_us * self.cos_g + sin_us * self.sin_g;
        let fu = (cos_au * self.b0 - self.b1) / sin_au;
        let f2 = fu * fu + self.b0 * self.b0;
        let xu = self.h.copysign(fu) / (f2 - 1.0).max(1e-12).sqrt();
        // max/min rather than clamp: a NaN lands on the edge.
        let xu = xu.max(self.x0).min(self.x1);
        // Along it, uniform in the sine of the elevation.
        let dist2 = xu * xu + h2;
        // Both ends' sines in one pair of lanes: one square root and one
        // division where two of each, one after the other, made the
        // sample wait (the same values bit for bit).
        let y = f32x4::new([self.y0, self.y1, 0.0, 0.0]);
        let [h0, h1, ..] = (y / (f32x4::splat(dist2) + y * y).sqrt()).to_array();
        let hv = h0 + u.y * (h1 - h0);
        let yv = hv * (dist2 / (1.0 - hv * hv).max(1e-12)).sqrt();
        let yv = yv.max(self.y0).min(self.y1);
        let uv = Vec2::new((xu - self.x0) * self.inv_w, (yv - self.y0) * self.inv_l)
            .clamp(Vec2::ZERO, Vec2::ONE);
        (self.corner + uv.x * self.ex + uv.y * self.ey, uv)
    }
}

/// The density of [`SphericalRectangle::sample`], 1/Ω, for the same
/// arguments as [`SphericalRectangle::new`]; `None` where that is.
#[inline]
pub fn spherical_rectangle_pdf(o: Vec3, r: &RectangleFrame) -> Option<f32> {
    let solid_angle = Corners::new(&LocalFrame::new(o, r)).solid_angle();
    (MIN_SOLID_ANGLE..=MAX_SOLID_ANGLE)
        .contains(&solid_angle)
        .then(|| 1.0 / solid_angle)
}

/// The rectangle in the frame at o with axes along its edges and its
/// normal pointing away from o: [x0, x1] × [y0, y1] at the distance h.
struct LocalFrame {
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    h: f32,
    inv_w: f32,
    inv_l: f32,
}

impl LocalFrame {
    #[inline]
    fn new(o: Vec3, r: &RectangleFrame) -> Self {
        let d = r.corner - o;
        let (x0, y0) = (d.dot(r.x), d.dot(r.y));
        Self {
            x0,
            x1: x0 + r.w,
            y0,
            y1: y0 + r.l,
            h: d.dot(r.z).abs(),
            inv_w: r.inv_w,
            inv_l: r.inv_l,
        }
    }
}

/// The rectangle's corners seen from the frame's origin, in the order
/// (x0, y0), (x1, y0), (x1, y1), (x0, y1), with their distances.
struct Corners {
    v: [Vec3; 4],
    len: [f32; 4],
}

impl Corners {
    #[inline]
    fn new(f: &LocalFrame) -> Self {
        let (x0, x1, y0, y1, z0) = (f.x0, f.x1, f.y0, f.y1, -f.h);
        let v = [
            Vec3::new(x0, y0, z0),
            Vec3::new(x1, y0, z0),
            Vec3::new(x1, y1, z0),
            Vec3::new(x0, y1, z0),
        ];
        // The four lengths in four lanes: one square root, not four (the
        // same sums in the same order as `Vec3::length`).
        let (x, y, z) = (
            f32x4::new([x0, x1, x1, x0]),
            f32x4::new([y0, y0, y1, y1]),
            f32x4::splat(z0),
        );
        Self {
            v,
            len: (x * x + y * y + z * z).sqrt().to_array(),
        }
    }

    /// The solid angle, as the sum of the two triangles' by Van Oosterom
    /// and Strackee: tan(Ω/2) = |a·(b×c)| / (|a||b||c| + (a·b)|c| +
    /// (a·c)|b| + (b·c)|a|), where both triangles' triple product is the
    /// rectangle's h·w·l.
    #[inline]
    fn solid_angle(&self) -> f32 {
        let [v00, _, v11, _] = self.v;
        let triple = v00.z.abs() * (v11.x - v00.x) * (v11.y - v00.y);
        let den = |a: usize, b: usize, c: usize| {
            let (va, vb, vc) = (self.v[a], self.v[b], self.v[c]);
            let (la, lb, lc) = (self.len[a], self.len[b], self.len[c]);
            la * lb * lc + va.dot(vb) * lc + va.dot(vc) * lb + vb.dot(vc) * la
        };
        // The two half-angles' sum in [0, π] is the argument of the
        // product of (den, triple) pairs as complex numbers: one
        // arctangent, not two. Their products reach length⁶, so f64.
        let (t, d0, d1) = (
            f64::from(triple),
            f64::from(den(0, 1, 2)),
            f64::from(den(0, 2, 3)),
        );
        2.0 * atan2_f64(t * (d0 + d1), d0 * d1 - t * t)
    }
}

/// Solid angle of [x0, x1] × [y0, y1] × {z0} seen from the origin.
#[cfg(test)]
fn rectangle_solid_angle(x0: f32, x1: f32, y0: f32, y1: f32, z0: f32) -> f32 {
    Corners::new(&LocalFrame {
        x0,
        x1,
        y0,
        y1,
        h: -z0,
        inv_w: 1.0 / (x1 - x0),
        inv_l: 1.0 / (y1 - y0),
    })
    .solid_angle()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;

    /// The solid angle against a midpoint-rule integral of cos/r² over the
    /// rectangle in f64, near and far, on and off axis.
    #[test]
    fn solid_angle_matches_integral() {
        for (x0, y0, z0, w, l) in [
            (-0.5f32, -0.5f32, -0.2f32, 1.0f32, 1.0f32),
            (0.3, -2.0, -0.7, 2.5, 0.4),
            (4.0, 3.0, -1.0, 0.3, 0.2),
            (-1.0, -1.0, -40.0, 0.5, 2.0),
            (-20.0, 5.0, -0.05, 1.5, 1.0),
        ] {
            let n = 1000;
            let mut sum = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let x = x0 as f64 + w as f64 * (i as f64 + 0.5) / n as f64;
                    let y = y0 as f64 + l as f64 * (j as f64 + 0.5) / n as f64;
                    let z = z0 as f64;
                    let r2 = x * x + y * y + z * z;
                    sum += -z / (r2 * r2.sqrt());
                }
            }
            let integral = sum * (w as f64 * l as f64) / (n * n) as f64;
            let omega = rectangle_solid_angle(x0, x0 + w, y0, y0 + l, z0) as f64;
            assert!(
                (omega - integral).abs() < 1e-4 * integral,
                "{omega} vs {integral} for {:?}",
                (x0, y0, z0, w, l)
            );
        }
    }

    /// Samples land on the rectangle at the coordinates they report, and
    /// the parametrization covers it: u = 0 and 1 reach opposite edges.
    #[test]
    fn samples_lie_on_the_rectangle() {
        let o = Vec3::new(0.3, -0.2, 0.9);
        let corner = Vec3::new(-0.4, -0.6, 0.2);
        let ex = Vec3::new(1.2, 0.3, 0.0);
        let ey = Vec3::new(-0.3, 1.2, 0.5).reject_from(ex).normalize() * 0.8;
        let sr = SphericalRectangle::new(o, &RectangleFrame::new(corner, ex, ey)).unwrap();
        let mut rng = Pcg32::new(1, 2);
        for _ in 0..1000 {
            let (p, uv) = sr.sample(rng.next_2d());
            let expect = corner + uv.x * ex + uv.y * ey;
            assert!((p - expect).length() < 1e-5, "{p} vs {expect}");
            assert!((0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y));
        }
        let (_, a) = sr.sample(Vec2::new(0.0, 0.0));
        let (_, b) = sr.sample(Vec2::new(1.0, 1.0));
        assert!(
            a.length() < 1e-3 && (b - Vec2::ONE).length() < 1e-3,
            "{a} {b}"
        );
    }

    #[test]
    fn far_and_in_plane_points_fall_back() {
        let frame = RectangleFrame::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        assert!(SphericalRectangle::new(Vec3::new(0.5, 0.5, 100.0), &frame).is_none());
        assert!(SphericalRectangle::new(Vec3::new(0.5, 0.5, 0.0), &frame).is_none());
        assert!(SphericalRectangle::new(Vec3::new(3.0, 0.5, 0.0), &frame).is_none());
        assert!(SphericalRectangle::new(Vec3::new(0.5, 0.5, 1.0), &frame).is_some());
    }
}
