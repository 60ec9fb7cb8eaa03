//! The pyroclastic density (seed 003's "pyroclastic cloud"; Ebert et al.,
//! "Texturing and Modeling: A Procedural Approach", and Wrenninge,
//! "Production Volume Rendering", 2012, §"pyroclastic noise"): a sphere
//! whose surface is pushed outwards along each direction by the magnitude
//! of fBm noise evaluated on the unit sphere, so the displacement is
//! radial and the cloud keeps a solid, billowing silhouette.
//!
//! With u = (p − centre)/|p − centre| and
//! h(u) = amplitude · |Σᵢ gainⁱ n(lacunarityⁱ · frequency · u + s)|
//! (n improved Perlin noise, s an offset chosen by `seed`), the density at
//! p is `density` · clamp((radius + h(u) − |p − centre|) / (edge · radius),
//! 0, 1): full inside the displaced surface, fading to zero over a shell
//! `edge` × radius thick.

use crate::texture::noise::perlin;
use glam::Vec3;

/// Lacunarity of the octaves (not 2, to avoid their aligned zeros).
const LACUNARITY: f32 = 1.92;
/// Amplitude ratio of successive octaves.
const GAIN: f32 = 0.5;

/// A pyroclastic sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pyroclastic {
    /// Centre of the sphere.
    pub center: Vec3,
    /// Radius of the undisplaced sphere.
    pub radius: f32,
    /// Largest displacement of one noise unit, in the units of `radius`.
    pub amplitude: f32,
    /// Octaves of fBm (1 to 16).
    pub octaves: u32,
    /// Frequency of the first octave on the unit sphere.
    pub frequency: f32,
    /// Density inside the cloud.
    pub density: f32,
    /// Thickness of the soft shell, as a fraction of `radius` (> 0).
    pub edge: f32,
    /// Offset of the noise, from the seed.
    offset: Vec3,
}

impl Pyroclastic {
    /// A cloud; `seed` picks the noise.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        center: Vec3,
        radius: f32,
        amplitude: f32,
        octaves: u32,
        frequency: f32,
        density: f32,
        edge: f32,
        seed: u32,
    ) -> Self {
        let h = |k: u32| crate::sampler::hash_u32(seed.wrapping_mul(0x9e37_79b9) ^ k) as f32;
        let offset = Vec3::new(h(1), h(2), h(3)) * (512.0 / u32::MAX as f32);
        Self {
            center,
            radius,
            amplitude,
            octaves: octaves.clamp(1, 16),
            frequency,
            density,
            edge: edge.max(1e-4),
            offset,
        }
    }

    /// The displacement along the unit direction `u`.
    fn displacement(&self, u: Vec3) -> f32 {
        let mut sum = 0.0;
        let (mut amp, mut freq) = (1.0, self.frequency);
        for _ in 0..self.octaves {
            sum += amp * perlin(u * freq + self.offset).0;
            amp *= GAIN;
            freq *= LACUNARITY;
        }
        self.amplitude * sum.abs()
    }

    /// The largest displacement there can be (|fBm| ≤ Σ gainⁱ with
    /// |n| ≤ 1).
    pub fn max_displacement(&self) -> f32 {
        self.amplitude * (1.0 - GAIN.powi(self.octaves as i32)) / (1.0 - GAIN)
    }

    /// The radius of a sphere about the centre outside which the density
    /// is zero.
    pub fn bounding_radius(&self) -> f32 {
        self.radius + self.max_displacement()
    }

    /// The density at `p`.
    pub fn eval(&self, p: Vec3) -> f32 {
        let v = p - self.center;
        let dist = v.length();
        if dist > self.bounding_radius() {
            return 0.0;
        }
        let u = if dist > 0.0 { v / dist } else { Vec3::Z };
        let surface = self.radius + self.displacement(u);
        self.density * ((surface - dist) / (self.edge * self.radius)).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;

    fn cloud(seed: u32) -> Pyroclastic {
        Pyroclastic::new(Vec3::new(1.0, 0.0, -2.0), 1.0, 0.4, 5, 2.0, 3.0, 0.05, seed)
    }

    /// Full inside the sphere, zero beyond the bound, an outline that
    /// varies with direction (the displacement is real), seeds that give
    /// different clouds and the same seed the same one.
    #[test]
    fn a_displaced_sphere_of_bounded_density() {
        let c = cloud(7);
        assert_eq!(c.eval(c.center), 3.0);
        let mut rng = Pcg32::new(2, 2);
        let mut radii = Vec::new();
        for _ in 0..200 {
            let u = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            assert_eq!(
                c.eval(c.center + u * 0.94),
                3.0,
                "inside the sphere less its shell"
            );
            assert_eq!(c.eval(c.center + u * (c.bounding_radius() + 1e-3)), 0.0);
            // The outline along u, by bisection on the density's edge.
            let (mut lo, mut hi) = (0.94f32, c.bounding_radius() + 1e-3);
            for _ in 0..30 {
                let mid = 0.5 * (lo + hi);
                if c.eval(c.center + u * mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            radii.push(lo);
        }
        let (min, max) = radii
            .iter()
            .fold((f32::MAX, 0.0f32), |(a, b), &r| (a.min(r), b.max(r)));
        assert!(
            max - min > 0.1,
            "outline between {min} and {max}: not displaced"
        );
        assert!(max <= c.bounding_radius() + 1e-3);
        let p = c.center + Vec3::new(1.1, 0.2, 0.0);
        assert_eq!(cloud(7).eval(p), c.eval(p));
        let differs = (0..50).any(|i| {
            let q = c.center + Vec3::new(1.0 + 0.01 * i as f32, 0.3, -0.2);
            cloud(8).eval(q) != c.eval(q)
        });
        assert!(differs, "another seed should give another cloud");
    }
}
