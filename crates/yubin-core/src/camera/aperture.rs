//! The aperture of a camera with a lens (`thinlens`, `physical`): where on
//! the lens a ray starts, how those points are distributed, and which of
//! them a second, virtual aperture in front of the lens lets through.
//!
//! Shapes: a disk (Shirley and Chiu's concentric mapping, as Mitsuba's
//! `thinlens` uses), or a regular n-gon inscribed in the disk, rotated by
//! `rotation` (a wedge per side, chosen uniformly, and a uniform point in
//! it). Bias: a point at fraction t of the way from the centre to the rim
//! (along its direction) moves to t^(1−b), so b > 0 pushes samples to the
//! rim and b < 0 to the centre; the area density is then
//! (1/A) · t'^(2b/(1−b)) / (1−b) at fraction t' (A the aperture's area).
//! Cat's eye: a virtual aperture of the same radius at distance `cats_eye`
//! in front of the lens, centred on the optical axis; a ray from lens
//! point a towards its focus point f passes when it crosses that plane
//! within the radius. On the axis nothing is lost; towards the image's
//! edges the two disks overlap in a lens ("cat's eye") shape and the image
//! darkens (optical vignetting).

use crate::sampling::square_to_uniform_disk_concentric;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A lens aperture in camera space (the lens in the z = 0 plane, looking
/// down +z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aperture {
    /// Radius (scene units); polygons are inscribed in this circle.
    pub radius: f32,
    /// Distance from the lens to the plane in focus (scene units).
    pub focus_distance: f32,
    /// 0 for a disk, else the polygon's number of sides (≥ 3).
    pub blades: u32,
    /// Rotation of the polygon about the axis (radians).
    pub rotation: f32,
    /// Bias b ∈ (−1, 1) of sample radii (see the module docs).
    pub bias: f32,
    /// Distance of the virtual aperture in front of the lens (scene
    /// units; 0: none).
    pub cats_eye: f32,
}

impl Aperture {
    /// A round, unbiased aperture (Mitsuba's `thinlens`).
    pub fn disk(radius: f32, focus_distance: f32) -> Self {
        Self {
            radius,
            focus_distance,
            blades: 0,
            rotation: 0.0,
            bias: 0.0,
            cats_eye: 0.0,
        }
    }

    /// A point on the lens for the uniform sample `u`.
    pub fn sample(&self, u: Vec2) -> Vec2 {
        let unit = if self.blades == 0 {
            square_to_uniform_disk_concentric(u)
        } else {
            self.sample_polygon(u)
        };
        let unit = if self.bias == 0.0 {
            unit
        } else {
            let t = self.rim_fraction(unit);
            if t > 0.0 {
                unit * t.powf(-self.bias)
            } else {
                unit
            }
        };
        unit * self.radius
    }

    /// A uniform point of the unit-circumradius polygon: a wedge per side.
    fn sample_polygon(&self, u: Vec2) -> Vec2 {
        let n = self.blades as f32;
        let scaled = u.x * n;
        let k = crate::math::floor(scaled).min(n - 1.0);
        let ux = scaled - k;
        let corner = |i: f32| {
            let a = self.rotation + 2.0 * PI * i / n;
            Vec2::new(a.cos(), a.sin())
        };
        // Uniform in the triangle (centre, corner k, corner k + 1).
        let su = ux.sqrt();
        let (b1, b2) = (su * (1.0 - u.y), su * u.y);
        corner(k) * b1 + corner(k + 1.0) * b2
    }

    /// How far `unit` (a point of the unit-circumradius shape) lies from
    /// the centre towards the rim along its direction, in [0, 1].
    fn rim_fraction(&self, unit: Vec2) -> f32 {
        if self.blades == 0 {
            return unit.length();
        }
        unit.length() / self.rim_distance(unit.y.atan2(unit.x))
    }

    /// Distance from the centre to the rim of the unit-circumradius shape
    /// in direction `angle`: 1 on a disk; on a polygon the apothem over the
    /// cosine of the angle from the side's normal.
    fn rim_distance(&self, angle: f32) -> f32 {
        if self.blades == 0 {
            return 1.0;
        }
        let n = self.blades as f32;
        let wedge = 2.0 * PI / n;
        let within = (angle - self.rotation).rem_euclid(wedge);
        (PI / n).cos() / (within - 0.5 * wedge).cos()
    }

    /// The aperture's area (scene units²).
    pub fn area(&self) -> f32 {
        let r2 = self.radius * self.radius;
        if self.blades == 0 {
            PI * r2
        } else {
            let n = self.blades as f32;
            0.5 * n * r2 * (2.0 * PI / n).sin()
        }
    }

    /// Area density of [`Aperture::sample`] at lens point `a`.
    pub fn pdf(&self, a: Vec2) -> f32 {
        let t = self.rim_fraction(a / self.radius);
        if t > 1.0 + 1e-5 {
            return 0.0;
        }
        let warp = if self.bias == 0.0 {
            1.0
        } else {
            let b = self.bias;
            t.powf(2.0 * b / (1.0 - b)) / (1.0 - b)
        };
        warp / self.area()
    }

    /// Whether the ray from lens point `a` towards the focus point
    /// `focus` (camera space, z > 0) passes the cat's-eye aperture.
    #[inline]
    pub fn passes(&self, a: Vec2, focus: Vec3) -> bool {
        if self.cats_eye <= 0.0 {
            return true;
        }
        let at = a + (focus.truncate() - a) * (self.cats_eye / focus.z);
        at.length_squared() <= self.radius * self.radius
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::testing::chi2::chi2_discrete;

    /// Aperture samples against the analytic density, binned in (t, φ):
    /// the fraction t of the way to the rim and the angle φ, where every
    /// shape fills the whole rectangle (no cell straddles the rim). The
    /// density there is p_A(point) · t ρ(φ)² r², ρ the rim distance.
    fn chi2_aperture(a: &Aperture) -> Result<(), String> {
        const NT: usize = 12;
        const NP: usize = 40;
        const SAMPLES: usize = 400_000;
        const SUB: usize = 8;
        let r = a.radius;
        let bin = |p: Vec2| -> usize {
            let unit = p / r;
            let t = a.rim_fraction(unit).min(0.99999);
            let phi = unit.y.atan2(unit.x).rem_euclid(2.0 * PI);
            let (i, j) = (
                (t * NT as f32) as usize,
                (phi / (2.0 * PI) * NP as f32) as usize,
            );
            i.min(NT - 1) * NP + j.min(NP - 1)
        };
        let mut counts = vec![0u64; NT * NP];
        let mut rng = Pcg32::new(17, 3);
        for _ in 0..SAMPLES {
            counts[bin(a.sample(rng.next_2d()))] += 1;
        }
        let (dt, dphi) = (1.0 / NT as f32, 2.0 * PI / NP as f32);
        let mut expected = vec![0.0f64; NT * NP];
        for (k, e) in expected.iter_mut().enumerate() {
            let (i, j) = ((k / NP) as f32, (k % NP) as f32);
            let mut sum = 0.0f64;
            for si in 0..SUB {
                for sj in 0..SUB {
                    let t = (i + (si as f32 + 0.5) / SUB as f32) * dt;
                    let phi = (j + (sj as f32 + 0.5) / SUB as f32) * dphi;
                    let rho = a.rim_distance(phi);
                    let p = Vec2::new(phi.cos(), phi.sin()) * (t * rho * r);
                    sum += (a.pdf(p) * t * rho * rho * r * r) as f64;
                }
            }
            *e = sum / (SUB * SUB) as f64 * (dt * dphi) as f64 * SAMPLES as f64;
        }
        chi2_discrete(&counts, &expected, 0.01 / 9.0)
    }

    /// Disk, pentagon and hexagon, each unbiased and biased both ways.
    #[test]
    fn chi2_aperture_shapes_and_biases() {
        let mut failures = Vec::new();
        for blades in [0, 5, 6] {
            for bias in [0.0, 0.5, -0.4] {
                let a = Aperture {
                    blades,
                    bias,
                    rotation: 0.3,
                    ..Aperture::disk(0.7, 3.0)
                };
                if let Err(e) = chi2_aperture(&a) {
                    failures.push(format!("blades {blades}, bias {bias}: {e}"));
                }
            }
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// A polygon's density integrates to one over its area (the pdf's
    /// normalization), biased or not.
    #[test]
    fn aperture_pdf_integrates_to_one() {
        for blades in [0, 3, 5, 8] {
            for bias in [0.0, 0.6, -0.5] {
                let a = Aperture {
                    blades,
                    bias,
                    rotation: 1.0,
                    ..Aperture::disk(2.0, 3.0)
                };
                let n = 800;
                let h = 4.0 / n as f32;
                let mut sum = 0.0f64;
                for i in 0..n {
                    for j in 0..n {
                        let p = Vec2::new(-2.0 + (i as f32 + 0.5) * h, -2.0 + (j as f32 + 0.5) * h);
                        sum += a.pdf(p) as f64 * (h * h) as f64;
                    }
                }
                assert!(
                    (sum - 1.0).abs() < 0.01,
                    "blades {blades} bias {bias}: {sum}"
                );
            }
        }
    }

    /// The cat's eye keeps every sample on the axis, and off it exactly
    /// those whose ray crosses the virtual aperture's plane inside it.
    #[test]
    fn cats_eye_removes_rim_samples_off_axis_only() {
        let a = Aperture {
            cats_eye: 1.0,
            ..Aperture::disk(0.5, 4.0)
        };
        let mut rng = Pcg32::new(1, 2);
        let on_axis = Vec3::new(0.0, 0.0, 4.0);
        let off_axis = Vec3::new(1.0, 0.5, 4.0);
        let (mut kept, mut total) = (0, 0);
        for _ in 0..10_000 {
            let p = a.sample(rng.next_2d());
            assert!(a.passes(p, on_axis), "{p} lost on the axis");
            let at = p + (off_axis.truncate() - p) * 0.25;
            assert_eq!(a.passes(p, off_axis), at.length() <= 0.5);
            // What is lost lies towards the rim, away from the image point.
            if !a.passes(p, off_axis) {
                assert!(p.dot(Vec2::new(1.0, 0.5)) > 0.0 && p.length() > 0.1, "{p}");
            } else {
                kept += 1;
            }
            total += 1;
        }
        assert!(kept > total / 4 && kept < total, "{kept} of {total} kept");
    }
}
