//! Rays, bounding boxes, orthonormal frames and transforms (`f32`, glam).

mod atan;
mod bounds;
mod frame;
mod transform;

pub use atan::{atan2, atan2_f64, atan2_pair};
pub(crate) use atan::{ATAN_UNIT, TAN_PI_8};
pub use bounds::Bounds3;
pub use frame::{coordinate_system, Frame};
pub use transform::Transform;

use glam::{Vec3, Vec3A};
use wide::f32x8;

/// Relative epsilon used to push spawned rays off surfaces (in units of
/// the hit point's magnitude), enough for `f32` intersection round-off.
pub const RAY_EPSILON: f32 = 1e-4;
/// Shadow rays stop this fraction short of their target.
pub const SHADOW_EPSILON: f32 = 1e-3;

/// A ray `o + t d`, valid for `t` in `[t_min, t_max]`. `d` need not be
/// normalized for intersection, but camera and BSDF rays keep it unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction.
    pub d: Vec3,
    /// Start of the valid interval.
    pub t_min: f32,
    /// End of the valid interval.
    pub t_max: f32,
}

impl Ray {
    /// An unbounded ray starting at `o`.
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Self {
            o,
            d,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }

    /// Origin and direction as SIMD vectors, for traversal set-up, each
    /// component read from memory on its own.
    ///
    /// A caller has usually just written the ray, in parts of its own
    /// choosing (three floats, or eight bytes and four). A load that spans
    /// two such stores still waiting in the store buffer cannot take its
    /// value from them, and waits until both reach the cache (failed
    /// store-to-load forwarding); a load within one store never waits.
    /// LLVM would merge neighbouring components into one wide load, so
    /// each goes through [`std::hint::black_box`], which it cannot see
    /// through; that costs a store and a load of one stack slot, which do
    /// forward, so traversal's set-up no longer waits on the caller's
    /// stores.
    #[inline(always)]
    pub fn vectors(&self) -> RayVectors {
        let read = |v: Vec3| {
            use std::hint::black_box;
            Vec3A::new(black_box(v.x), black_box(v.y), black_box(v.z))
        };
        RayVectors {
            o: read(self.o),
            d: read(self.d),
        }
    }
}

/// A ray's origin and direction as SIMD vectors (see [`Ray::vectors`]).
#[derive(Clone, Copy, Debug)]
pub struct RayVectors {
    /// Origin.
    pub o: Vec3A,
    /// Direction.
    pub d: Vec3A,
}

/// Eight rays, structure of arrays: per axis a lane per ray, for testing
/// one shape against all of them at once.
#[derive(Clone, Copy, Debug)]
pub struct RayPacket {
    /// Origins.
    pub o: [f32x8; 3],
    /// Directions.
    pub d: [f32x8; 3],
    /// Starts of the valid intervals.
    pub t_min: f32x8,
}

impl RayPacket {
    /// The packet of `rays`.
    #[inline(always)]
    pub fn new(rays: &[Ray; 8]) -> Self {
        Self {
            o: std::array::from_fn(|a| f32x8::new(std::array::from_fn(|l| rays[l].o[a]))),
            d: std::array::from_fn(|a| f32x8::new(std::array::from_fn(|l| rays[l].d[a]))),
            t_min: f32x8::new(rays.map(|r| r.t_min)),
        }
    }
}

/// `e^x`, with the arguments whose exponential is 0 in `f32` answered
/// without libm: its `expf` sends them to an out-of-line underflow
/// handler that sets `errno`, and Beckmann's distribution and masking
/// meet them at every grazing half vector, so the slow path is a common
/// one there. The same values bit for bit: `expf` is 0 below about −103.97.
#[inline]
pub fn exp_or_zero(x: f32) -> f32 {
    if x < -104.0 {
        0.0
    } else {
        x.exp()
    }
}

/// ⌊x⌋, the same as `f32::floor` bit for bit, by truncation: baseline
/// x86-64 has no rounding instruction, and `floor` calls a software
/// `floorf` (once per texture lookup, e.g. a checkerboard's cell). At and
/// beyond 2²³ every float is an integer already; NaN stays NaN and −0
/// stays −0.
#[inline]
pub fn floor(x: f32) -> f32 {
    if x.abs() < 8_388_608.0 {
        let t = x as i32 as f32;
        (if t > x { t - 1.0 } else { t }).copysign(x)
    } else {
        x
    }
}

/// [`floor`] of both components.
#[inline]
pub fn floor2(v: glam::Vec2) -> glam::Vec2 {
    glam::Vec2::new(floor(v.x), floor(v.y))
}

/// [`floor`] of the three components.
#[inline]
pub fn floor3(v: Vec3) -> Vec3 {
    Vec3::new(floor(v.x), floor(v.y), floor(v.z))
}

/// sin a and cos a for |a| ≤ π/4, without libm's range reduction and call
/// (the concentric disk map, used by every cosine-weighted sample, only
/// needs this interval): Cephes' minimax polynomials for that interval
/// (Moshier 1989, "Methods and Programs for Mathematical Functions";
/// `sinf.c`), within 2·10⁻⁷ of the exact values (`quarter_sin_cos_is_accurate`).
#[inline]
pub fn sin_cos_quarter(a: f32) -> (f32, f32) {
    let ([s0, s1, s2], [c0, c1, c2]) = (SIN_QUARTER, COS_QUARTER);
    let z = a * a;
    let sin = ((s0 * z + s1) * z - s2) * z * a + a;
    let cos = ((c0 * z - c1) * z + c2) * z * z - 0.5 * z + 1.0;
    (sin, cos)
}

/// The coefficients of [`sin_cos_quarter`]'s sine polynomial (also read
/// by its eight-lane twin).
pub(crate) const SIN_QUARTER: [f32; 3] = [-1.951_529_6e-4, 8.332_161e-3, 1.666_665_5e-1];
/// The coefficients of its cosine polynomial.
pub(crate) const COS_QUARTER: [f32; 3] = [2.443_315_7e-5, 1.388_731_6e-3, 4.166_664_6e-2];

/// π/2's leading 17 bits, so that k·`PIO2_HI` is exact for the quadrant
/// counts k of [`sin_cos`] (Cody and Waite's two-part reduction).
pub(crate) const PIO2_HI: f32 = 1.570_785_5;
/// π/2 − [`PIO2_HI`].
pub(crate) const PIO2_LO: f32 = 1.080_433_4e-5;
/// 1.5·2²³: adding and subtracting it rounds an f32 below 2²² in magnitude
/// to the nearest integer (ties to even) with plain arithmetic, which
/// eight-lane code does the same way (baseline x86-64 has no rounding
/// instruction, and `round_ties_even` would call libm).
pub(crate) const ROUND_TO_INTEGER: f32 = 12_582_912.0;

/// sin a and cos a for |a| up to about 200 (where k·[`PIO2_HI`] stays
/// exact), without a libm call, by the quadrant: a = kπ/2 + r with
/// |r| ≤ π/4, then [`sin_cos_quarter`] of r turned by k quarter turns;
/// within 3·10⁻⁷ of the exact values on [−2π, 2π] (`sin_cos_is_accurate`). Plain arithmetic and selects, so
/// eight lanes at a time give the same values bit for bit (the path
/// tracer's wide light sampling).
#[inline]
pub fn sin_cos(a: f32) -> (f32, f32) {
    let k = (a * std::f32::consts::FRAC_2_PI + ROUND_TO_INTEGER) - ROUND_TO_INTEGER;
    let (s, c) = sin_cos_quarter((a - k * PIO2_HI) - k * PIO2_LO);
    match k as i32 & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Offsets `p` along the geometric normal `n`, to the side that `d` points
/// to, so that a ray leaving a surface doesn't hit it again.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3, d: Vec3) -> Vec3 {
    let mag = (1.0 + p.abs().max_element()) * RAY_EPSILON;
    let offset = n * mag;
    if n.dot(d) >= 0.0 {
        p + offset
    } else {
        p - offset
    }
}

/// A ray leaving surface point `p` (geometric normal `n`) in direction `d`.
#[inline]
pub fn spawn_ray(p: Vec3, n: Vec3, d: Vec3) -> Ray {
    Ray::new(offset_ray_origin(p, n, d), d)
}

/// A shadow ray from surface point `p` (normal `n`) to `target`, stopping
/// just short of it; `d` is unit length and `t_max` the distance.
#[inline]
pub fn spawn_ray_to(p: Vec3, n: Vec3, target: Vec3) -> Ray {
    let o = offset_ray_origin(p, n, target - p);
    let delta = target - o;
    let dist = delta.length();
    Ray {
        o,
        d: delta / dist,
        t_min: 0.0,
        t_max: dist * (1.0 - SHADOW_EPSILON),
    }
}

/// [`spawn_ray_to`] for a visibility test alone: `d` is the whole offset
/// from the origin to `target`, not a unit vector, and `t_max` just short
/// of 1. No square root and division stand between the light sample and
/// the traversal (every shape's test takes any direction's length).
#[inline]
pub fn shadow_ray_to(p: Vec3, n: Vec3, target: Vec3) -> Ray {
    let o = offset_ray_origin(p, n, target - p);
    Ray {
        o,
        d: target - o,
        t_min: 0.0,
        t_max: 1.0 - SHADOW_EPSILON,
    }
}

#[cfg(test)]
mod tests {
    /// `floor` is `f32::floor` bit for bit: around every integer to 2²⁴,
    /// at signed zeros, tiny, huge, infinite and NaN values.
    #[test]
    fn floor_equals_libm() {
        let mut values = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1e-30,
            -1e-30,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_609.0,
            3e9,
            -3e9,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        let mut k = 1.0f32;
        while k < 16_777_216.0 {
            for v in [k, -k] {
                values.extend([v, v.next_up(), v.next_down(), v + 0.5, v - 0.5]);
            }
            k *= 1.37;
        }
        for v in values {
            assert_eq!(super::floor(v).to_bits(), v.floor().to_bits(), "floor {v}");
        }
        assert!(super::floor(f32::NAN).is_nan());
    }

    /// Within 2·10⁻⁷ of the exact sine and cosine over [−π/4, π/4],
    /// where an error of 10⁻⁶ (a coefficient's fourth digit) fails.
    #[test]
    fn quarter_sin_cos_is_accurate() {
        let n = 200_000;
        for i in 0..=n {
            let a = std::f32::consts::FRAC_PI_4 * (2.0 * i as f32 / n as f32 - 1.0);
            let (s, c) = super::sin_cos_quarter(a);
            let exact = (a as f64).sin_cos();
            assert!(
                (s as f64 - exact.0).abs() < 2e-7,
                "sin {a}: {s} vs {}",
                exact.0
            );
            assert!(
                (c as f64 - exact.1).abs() < 2e-7,
                "cos {a}: {c} vs {}",
                exact.1
            );
        }
    }

    #[test]
    fn sin_cos_is_accurate() {
        let n = 400_000;
        for i in 0..=n {
            let a = std::f32::consts::TAU * (2.0 * i as f32 / n as f32 - 1.0);
            let (s, c) = super::sin_cos(a);
            let exact = (a as f64).sin_cos();
            assert!(
                (s as f64 - exact.0).abs() < 3e-7 && (c as f64 - exact.1).abs() < 3e-7,
                "{a}: ({s}, {c}) vs {exact:?}"
            );
        }
        assert_eq!(super::sin_cos(0.0), (0.0, 1.0));
    }

    #[test]
    fn exp_or_zero_is_exp() {
        for x in [-200.0f32, -104.0, -103.98, -103.9, -87.5, -10.0, 0.0, 3.0] {
            assert_eq!(super::exp_or_zero(x).to_bits(), x.exp().to_bits(), "{x}");
        }
    }

    use super::*;

    #[test]
    fn ray_vectors_hold_origin_and_direction_bit_for_bit() {
        // Signed zeros and extreme values must survive the component-wise
        // read: the slab test takes the sign of a zero direction from it.
        let ray = Ray::new(Vec3::new(1.5, -0.0, 3e38), Vec3::new(-0.0, 0.0, -1e-30));
        let v = ray.vectors();
        let bits = |a: Vec3A| a.to_array().map(f32::to_bits);
        assert_eq!(bits(v.o), Vec3A::from(ray.o).to_array().map(f32::to_bits));
        assert_eq!(bits(v.d), Vec3A::from(ray.d).to_array().map(f32::to_bits));
    }
}
