//! Uniform sampling of the solid angle a triangle subtends from a point,
//! by Arvo's inversion of the spherical triangle's area ("Stratified
//! Sampling of Spherical Triangles", SIGGRAPH 1995): the first coordinate
//! picks the sub-triangle A B Ĉ of the wanted fraction of the area, the
//! second a point on the arc from B to Ĉ, uniform in the cosine of its
//! distance from B. Every sample has the density 1/Ω.

use super::{SPHERICAL_MAX_SOLID_ANGLE, SPHERICAL_MIN_SOLID_ANGLE};
use crate::math::atan2;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A triangle as seen from a point, ready to be sampled.
#[derive(Clone, Copy, Debug)]
pub struct SphericalTriangle {
    /// Unit directions to the vertices.
    a: Vec3,
    b: Vec3,
    c: Vec3,
    /// The spherical angle at A, its sine and cosine.
    alpha: f32,
    sin_alpha: f32,
    cos_alpha: f32,
    /// The solid angle.
    solid_angle: f32,
}

impl SphericalTriangle {
    /// The triangle `v` seen from `o`; `None` when its solid angle lies
    /// outside [`SPHERICAL_MIN_SOLID_ANGLE`], [`SPHERICAL_MAX_SOLID_ANGLE`]
    /// (then sample by area).
    #[inline]
    pub fn new(o: Vec3, v: [Vec3; 3]) -> Option<Self> {
        let [a, b, c] = v.map(|p| (p - o).normalize_or_zero());
        // Normals of the great circles through each side.
        let (n_ab, n_bc, n_ca) = (
            a.cross(b).normalize_or_zero(),
            b.cross(c).normalize_or_zero(),
            c.cross(a).normalize_or_zero(),
        );
        // The angle at each vertex, between the circles meeting there.
        let angle = |n1: Vec3, n2: Vec3| atan2(n1.cross(n2).length(), -n1.dot(n2));
        let alpha = angle(n_ab, n_ca);
        let beta = angle(n_bc, n_ab);
        let gamma = angle(n_ca, n_bc);
        let solid_angle = alpha + beta + gamma - PI;
        if !(SPHERICAL_MIN_SOLID_ANGLE..=SPHERICAL_MAX_SOLID_ANGLE).contains(&solid_angle) {
            return None;
        }
        let (sin_alpha, cos_alpha) = alpha.sin_cos();
        Some(Self {
            a,
            b,
            c,
            alpha,
            sin_alpha,
            cos_alpha,
            solid_angle,
        })
    }

    /// The solid angle the triangle subtends (sr).
    #[inline]
    pub fn solid_angle(&self) -> f32 {
        self.solid_angle
    }

    /// A unit direction towards the triangle, uniform in solid angle.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let (a, b, c) = (self.a, self.b, self.c);
        // Ĉ on the arc from A to C closes the sub-triangle A B Ĉ of area
        // u.x Ω.
        let (s, t) = (u.x * self.solid_angle - self.alpha).sin_cos();
        let uu = t - self.cos_alpha;
        let vv = s + self.sin_alpha * a.dot(b);
        let q = (((vv * t - uu * s) * self.cos_alpha - vv) / ((vv * s + uu * t) * self.sin_alpha))
            .clamp(-1.0, 1.0);
        let c_hat =
            q * a + (1.0 - q * q).max(0.0).sqrt() * c.reject_from_normalized(a).normalize_or_zero();
        // Along the arc from B to Ĉ, uniform in the cosine from B.
        let z = 1.0 - u.y * (1.0 - c_hat.dot(b));
        z * b + (1.0 - z * z).max(0.0).sqrt() * c_hat.reject_from_normalized(b).normalize_or_zero()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;

    /// The solid angle against a midpoint-rule integral of cos/r² over the
    /// triangle in f64.
    #[test]
    fn solid_angle_matches_integral() {
        for (o, v) in [
            (Vec3::new(0.2, 0.3, 1.0), [Vec3::ZERO, Vec3::X, Vec3::Y]),
            (
                Vec3::new(-1.0, 2.0, 0.4),
                [
                    Vec3::ZERO,
                    Vec3::new(2.0, 0.5, 0.0),
                    Vec3::new(0.3, 1.5, 0.0),
                ],
            ),
            (Vec3::new(0.3, 0.3, -0.2), [Vec3::ZERO, Vec3::X, Vec3::Y]),
        ] {
            let n = 1000;
            let (e1, e2) = ((v[1] - v[0]).as_dvec3(), (v[2] - v[0]).as_dvec3());
            let normal = e1.cross(e2);
            let area = 0.5 * normal.length();
            let normal = normal.normalize();
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n - i {
                    // Centroids of the small triangles of a regular split.
                    for (di, dj) in [(1.0 / 3.0, 1.0 / 3.0), (2.0 / 3.0, 2.0 / 3.0)] {
                        let (s, t) = ((i as f64 + di) / n as f64, (j as f64 + dj) / n as f64);
                        if s + t > 1.0 {
                            continue;
                        }
                        let p = v[0].as_dvec3() + s * e1 + t * e2;
                        let d = p - o.as_dvec3();
                        let r2 = d.length_squared();
                        sum += (normal.dot(d)).abs() / (r2 * r2.sqrt());
                    }
                }
            }
            let integral = sum * area / (n * n) as f64;
            let st = SphericalTriangle::new(o, v).unwrap();
            let omega = st.solid_angle() as f64;
            assert!(
                (omega - integral).abs() < 1e-3 * integral,
                "{omega} vs {integral}"
            );
            // Samples point into the triangle.
            let mut rng = Pcg32::new(2, 3);
            for _ in 0..1000 {
                let d = st.sample(rng.next_2d());
                assert!((d.length() - 1.0).abs() < 1e-4);
                let t = (v[0] - o).dot(normal.as_vec3()) / d.dot(normal.as_vec3());
                let p = o + t * d;
                let b = barycentric(p, v);
                assert!(t > 0.0 && b.min_element() > -1e-3, "{p} outside {v:?}: {b}");
            }
        }
    }

    fn barycentric(p: Vec3, v: [Vec3; 3]) -> Vec3 {
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        let w = |a: Vec3, b: Vec3| (b - a).cross(p - a).dot(n) / n.length_squared();
        Vec3::new(w(v[1], v[2]), w(v[2], v[0]), w(v[0], v[1]))
    }
}
