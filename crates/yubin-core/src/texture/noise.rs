//! Shared code of the noise textures (`perlin`, `fbm`): Ken Perlin's
//! improved gradient noise with its analytic gradient, where a hit is in
//! noise space ([`NoiseSpace`]), and how a noise value becomes a colour
//! ([`NoiseMap`]). Not a plugin itself.
//!
//! Noise (Perlin 2002, "Improving Noise", SIGGRAPH): the integer lattice
//! carries pseudo-random gradients picked by hashing the corner through a
//! fixed permutation of 0..256 (the table published with the paper); the
//! noise at p is the interpolation of the eight corner ramps
//! g_c · (p − c) with the quintic fade 6t⁵ − 15t⁴ + 10t³ (whose first and
//! second derivatives vanish at the lattice, unlike the 1985 cubic), and
//! the gradients are the 12 directions from the centre of a cube to its
//! edges' midpoints, padded to 16 with (1,1,0), (−1,1,0), (0,−1,1) and
//! (0,−1,−1) so that the hash picks one with a bit mask. The noise is zero
//! at every lattice point and repeats with period 256 on each axis.

use super::{uv_transform_param, Tex};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ColorKind, ParamError, Params};
use crate::Rgb;
use glam::{Affine2, Affine3A, Vec2, Vec3};

/// The permutation of 0..256 published with Perlin 2002.
const PERM: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

/// The 12 cube-edge directions and the 4 that pad them to 16 (Perlin 2002).
const GRADIENTS: [[f32; 3]; 16] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [0.0, -1.0, 1.0],
    [0.0, -1.0, -1.0],
];

/// The gradient at lattice corner (x, y, z) (each taken modulo 256).
#[inline]
fn gradient(x: i32, y: i32, z: i32) -> Vec3 {
    let h = |i: i32| PERM[(i & 255) as usize] as i32;
    let g = GRADIENTS[(h(h(h(x) + y) + z) & 15) as usize];
    Vec3::from_array(g)
}

/// The quintic fade 6t⁵ − 15t⁴ + 10t³ and its derivative 30t²(t − 1)².
#[inline]
fn fade(t: Vec3) -> (Vec3, Vec3) {
    let s = t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let u = t * (t - 1.0);
    (s, u * u * 30.0)
}

/// Improved Perlin noise at `p` and its gradient ∂n/∂p. The value stays
/// within [−1, 1] in practice (its extremes, near ±1, are where several
/// corner gradients point the same way; the tests check the bound over
/// random points for this table, not a proof for every permutation).
#[inline]
pub fn perlin(p: Vec3) -> (f32, Vec3) {
    if !p.is_finite() {
        return (0.0, Vec3::ZERO);
    }
    let cell = crate::math::floor3(p);
    let f = p - cell;
    let (ix, iy, iz) = (cell.x as i32, cell.y as i32, cell.z as i32);
    let (s, ds) = fade(f);
    let mut value = 0.0;
    let mut grad = Vec3::ZERO;
    for c in 0..8 {
        let (cx, cy, cz) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
        let g = gradient(ix + cx, iy + cy, iz + cz);
        let d = f - Vec3::new(cx as f32, cy as f32, cz as f32);
        let ramp = g.dot(d);
        // Weight of this corner per axis (s or 1 − s) and its derivative.
        let pick = |on: i32, s: f32, ds: f32| if on == 1 { (s, ds) } else { (1.0 - s, -ds) };
        let (wx, dwx) = pick(cx, s.x, ds.x);
        let (wy, dwy) = pick(cy, s.y, ds.y);
        let (wz, dwz) = pick(cz, s.z, ds.z);
        let w = wx * wy * wz;
        value += w * ramp;
        grad += w * g + ramp * Vec3::new(dwx * wy * wz, wx * dwy * wz, wx * wy * dwz);
    }
    (value, grad)
}

/// Where a hit is in noise space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoiseSpace {
    /// A solid texture: the world position through this map (the inverse
    /// of `to_world`, times `scale`).
    World(Affine3A),
    /// The surface's uv through this map (`to_uv`, times `scale`), at
    /// z = 0.
    Uv(Affine2),
}

impl NoiseSpace {
    /// The noise-space point at `si` and its derivatives with respect to
    /// (u, v).
    #[inline]
    pub fn point(&self, si: &SurfaceInteraction) -> (Vec3, Vec3, Vec3) {
        match self {
            NoiseSpace::World(m) => (
                m.transform_point3(si.p),
                m.transform_vector3(si.dpdu),
                m.transform_vector3(si.dpdv),
            ),
            NoiseSpace::Uv(m) => (
                m.transform_point2(si.uv).extend(0.0),
                m.matrix2.x_axis.extend(0.0),
                m.matrix2.y_axis.extend(0.0),
            ),
        }
    }

    /// A scalar field `f` (value and gradient in noise space) at `si`, with
    /// its derivative with respect to (u, v) by the chain rule.
    #[inline]
    pub fn eval_grad(
        &self,
        si: &SurfaceInteraction,
        f: impl Fn(Vec3) -> (f32, Vec3),
    ) -> (f32, Vec2) {
        let (p, dpdu, dpdv) = self.point(si);
        let (n, g) = f(p);
        (n, Vec2::new(g.dot(dpdu), g.dot(dpdv)))
    }
}

/// A noise texture's space and colours: noise n becomes
/// t = clamp(½(n + 1), 0, 1) and the colour (1 − t)·`color0` + t·`color1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseMap {
    /// Where the noise is evaluated.
    pub space: NoiseSpace,
    /// The colour where the noise is −1.
    pub color0: Tex,
    /// The colour where the noise is +1.
    pub color1: Tex,
}

impl NoiseMap {
    /// Reads `space`, `to_world`, `to_uv`, `scale`, `color0` and `color1`.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let uv = p.choice("space", &["world", "uv"])? == 1;
        let scale = p.positive_float_or("scale", 1.0)?;
        let (unused, space) = if uv {
            let to_uv = uv_transform_param(p)?;
            let m = Affine2::from_scale(Vec2::splat(scale)) * to_uv;
            ("to_world", NoiseSpace::Uv(m))
        } else {
            let to_world = p.transform_or_identity("to_world")?;
            let m = Affine3A::from_scale(Vec3::splat(scale)) * to_world.inv;
            ("to_uv", NoiseSpace::World(m))
        };
        if p.has(unused) {
            let used = if uv { "uv" } else { "world" };
            return Err(p.param_error(
                unused,
                &format!("has no effect with space=\"{used}\" (use the other transform)"),
            ));
        }
        Ok(Self {
            space,
            color0: p.texture_or("color0", ColorKind::Reflectance, Rgb::ZERO)?,
            color1: p.texture_or("color1", ColorKind::Reflectance, Rgb::ONE)?,
        })
    }

    /// The blend weight t for noise `n`, and dt/dn (zero where clamped).
    #[inline]
    fn weight(n: f32) -> (f32, f32) {
        let t = 0.5 * (n + 1.0);
        if (0.0..=1.0).contains(&t) {
            (t, 0.5)
        } else {
            (t.clamp(0.0, 1.0), 0.0)
        }
    }

    /// The colour for noise `n` at `si`.
    #[inline]
    pub fn eval(&self, m: &Materials, si: &SurfaceInteraction, n: f32) -> Rgb {
        let (t, _) = Self::weight(n);
        self.color0.eval(m, si).lerp(self.color1.eval(m, si), t)
    }

    /// The value for noise `n` at `si`.
    #[inline]
    pub fn eval_1(&self, m: &Materials, si: &SurfaceInteraction, n: f32) -> f32 {
        let (t, _) = Self::weight(n);
        let (a, b) = (self.color0.eval_1(m, si), self.color1.eval_1(m, si));
        a + t * (b - a)
    }

    /// The value and its (u, v) derivative for noise `n` with derivative
    /// `dn` (product rule through the colours, which may be textures).
    #[inline]
    pub fn eval_1_grad(
        &self,
        m: &Materials,
        si: &SurfaceInteraction,
        n: f32,
        dn: Vec2,
    ) -> (f32, Vec2) {
        let (t, dtdn) = Self::weight(n);
        let (a, da) = self.color0.eval_1_grad(m, si);
        let (b, db) = self.color1.eval_1_grad(m, si);
        (
            a + t * (b - a),
            da * (1.0 - t) + db * t + dn * (dtdn * (b - a)),
        )
    }

    /// The mean: the colours' average (t = ½, the noise averaging zero).
    pub fn mean(&self, m: &Materials) -> f32 {
        0.5 * (self.color0.mean(m) + self.color1.mean(m))
    }
}

/// Checks that a noise texture's `TextureModel` gradient matches central
/// differences of its `eval_1` in u and v at `si` (moving p along ∂p/∂u
/// and ∂p/∂v with uv; shared by the procedural textures' tests).
#[cfg(test)]
pub(crate) fn check_gradient(t: &impl super::TextureModel, m: &Materials, si: &SurfaceInteraction) {
    let (v, g) = t.eval_1_grad(m, si);
    assert!((v - t.eval_1(m, si)).abs() < 1e-5);
    let h = 1e-3;
    let at = |du: f32, dv: f32| {
        let s = SurfaceInteraction {
            uv: si.uv + Vec2::new(du, dv),
            p: si.p + si.dpdu * du + si.dpdv * dv,
            ..*si
        };
        t.eval_1(m, &s)
    };
    let fd = Vec2::new(
        (at(h, 0.0) - at(-h, 0.0)) / (2.0 * h),
        (at(0.0, h) - at(0.0, -h)) / (2.0 * h),
    );
    assert!(
        (g - fd).length() < 2e-2 * (1.0 + g.length()),
        "analytic {g} vs finite differences {fd}"
    );
}

/// A fixed-seed stream of uniform numbers in [0, 1), for tests.
#[cfg(test)]
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_a_permutation() {
        let mut seen = [false; 256];
        for &v in &PERM {
            assert!(!seen[v as usize], "{v} twice");
            seen[v as usize] = true;
        }
    }

    #[test]
    fn fade_is_flat_at_both_ends() {
        let (s, ds) = fade(Vec3::new(0.0, 1.0, 0.5));
        assert_eq!(s, Vec3::new(0.0, 1.0, 0.5));
        assert_eq!((ds.x, ds.y), (0.0, 0.0));
        assert!((ds.z - 1.875).abs() < 1e-6);
    }

    #[test]
    fn zero_at_lattice_points_and_bounded() {
        for (x, y, z) in [(0, 0, 0), (1, 2, 3), (-7, 4, 255), (300, -41, 9)] {
            let (n, _) = perlin(Vec3::new(x as f32, y as f32, z as f32));
            assert_eq!(n, 0.0, "at ({x}, {y}, {z})");
        }
        let mut u = uniform(7);
        let mut max = 0.0f32;
        for _ in 0..200_000 {
            let p = Vec3::new(u(), u(), u()) * 64.0 - 32.0;
            max = max.max(perlin(p).0.abs());
        }
        assert!(max <= 1.0, "max |n| = {max}");
        // The noise does vary: a bound this loose would hide a dead field.
        assert!(max > 0.7, "max |n| = {max}");
    }

    #[test]
    fn periodic_with_period_256() {
        let p = Vec3::new(0.3, 1.7, -2.2);
        let (a, ga) = perlin(p);
        let (b, gb) = perlin(p + Vec3::new(256.0, -256.0, 512.0));
        assert!((a - b).abs() < 1e-4 && (ga - gb).length() < 1e-3);
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let mut u = uniform(3);
        let h = 1e-3;
        for _ in 0..200 {
            let p = Vec3::new(u(), u(), u()) * 16.0 - 8.0;
            let (_, g) = perlin(p);
            let fd = Vec3::new(
                perlin(p + Vec3::X * h).0 - perlin(p - Vec3::X * h).0,
                perlin(p + Vec3::Y * h).0 - perlin(p - Vec3::Y * h).0,
                perlin(p + Vec3::Z * h).0 - perlin(p - Vec3::Z * h).0,
            ) / (2.0 * h);
            assert!((g - fd).length() < 1e-2, "at {p}: {g} vs {fd}");
        }
    }

    #[test]
    fn mean_is_near_zero() {
        let mut u = uniform(11);
        let n = 100_000;
        let sum: f64 = (0..n)
            .map(|_| perlin(Vec3::new(u(), u(), u()) * 200.0).0 as f64)
            .sum();
        assert!((sum / n as f64).abs() < 0.01, "mean {}", sum / n as f64);
    }
}
