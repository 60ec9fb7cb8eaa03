//! An arctangent without a libm call, for the per-ray angle lookups
//! (environment maps' latitude–longitude coordinates, the sphere's and
//! other round shapes' φ and θ): one reduction to
//! |t| ≤ tan(π/8) and Moshier's Cephes `atanf` polynomial, whose error
//! there is about 10⁻⁷ (S. L. Moshier, *Methods and Programs for
//! Mathematical Functions*, 1989), with the octant folded back by
//! selects rather than branches: which octant a ray's direction falls in
//! is a coin flip per ray.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use wide::{f32x4, CmpGt, CmpLt};

/// tan(π/8).
pub(crate) const TAN_PI_8: f32 = 0.414_213_57;

/// The coefficients of [`atan_unit`]'s polynomial (also read by its
/// lane-wise twins).
pub(crate) const ATAN_UNIT: [f32; 4] =
    [8.053_744_5e-2, 1.387_768_6e-1, 1.997_771_1e-1, 3.333_295e-1];

/// atan(a) for a in [0, 1].
#[inline]
fn atan_unit(a: f32) -> f32 {
    let reduce = a > TAN_PI_8;
    let t = if reduce { (a - 1.0) / (a + 1.0) } else { a };
    let [a0, a1, a2, a3] = ATAN_UNIT;
    let z = t * t;
    let p = (((a0 * z - a1) * z + a2) * z - a3) * z * t + t;
    if reduce {
        FRAC_PI_4 + p
    } else {
        p
    }
}

/// The angle of (x, y) in (−π, π], as `y.atan2(x)` (0 at the origin; the
/// sign of a zero y is not kept: ±0 both give 0 or π).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay > ax { (ax, ay) } else { (ay, ax) };
    let a = if hi > 0.0 { lo / hi } else { 0.0 };
    unfold(atan_unit(a), ay > ax, x < 0.0, y < 0.0)
}

/// [`atan2`] of an (x, y) given in f64, whose components may lie beyond
/// f32's range: only their ratio is taken to f32.
#[inline]
pub fn atan2_f64(y: f64, x: f64) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay > ax { (ax, ay) } else { (ay, ax) };
    let a = if hi > 0.0 { (lo / hi) as f32 } else { 0.0 };
    unfold(atan_unit(a), ay > ax, x < 0.0, y < 0.0)
}

/// The angle in (−π, π] whose first-octant fold is `r`: reflected across
/// the diagonal when `steep`, then to x < 0 and y < 0.
#[inline]
fn unfold(r: f32, steep: bool, x_negative: bool, y_negative: bool) -> f32 {
    let r = if steep { FRAC_PI_2 - r } else { r };
    let r = if x_negative { PI - r } else { r };
    if y_negative {
        -r
    } else {
        r
    }
}

/// [`atan2`] of two (y, x) pairs at once: lane by lane the same
/// operations, so the same angles bit for bit, with the two angles'
/// chains of division and polynomial side by side in SSE lanes instead
/// of one after the other: a direction's latitude–longitude coordinates,
/// which environment-map lookups wait on. (Pairing a sphere's φ and θ or
/// a rectangle's two solid angles the same way gained nothing, so those
/// stay scalar.)
#[inline]
pub fn atan2_pair(y: [f32; 2], x: [f32; 2]) -> [f32; 2] {
    let s = f32x4::splat;
    let (y, x) = (
        f32x4::new([y[0], y[1], 0.0, 0.0]),
        f32x4::new([x[0], x[1], 0.0, 0.0]),
    );
    let (ax, ay) = (x.abs(), y.abs());
    let steep = ay.cmp_gt(ax);
    let (lo, hi) = (steep.blend(ax, ay), steep.blend(ay, ax));
    let a = hi.cmp_gt(f32x4::ZERO).blend(lo / hi, f32x4::ZERO);
    // atan_unit, lane by lane.
    let reduce = a.cmp_gt(s(TAN_PI_8));
    let t = reduce.blend((a - f32x4::ONE) / (a + f32x4::ONE), a);
    let z = t * t;
    let [a0, a1, a2, a3] = ATAN_UNIT.map(s);
    let p = ((((a0 * z - a1) * z + a2) * z - a3) * z) * t + t;
    let r = reduce.blend(s(FRAC_PI_4) + p, p);
    let r = steep.blend(s(FRAC_PI_2) - r, r);
    let r = x.cmp_lt(f32x4::ZERO).blend(s(PI) - r, r);
    // Negated by the sign bit, as `-r` is (0 − r would turn −0 into +0).
    let r = y.cmp_lt(f32x4::ZERO).blend(r ^ s(-0.0), r);
    let [a0, a1, ..] = r.to_array();
    [a0, a1]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paired arctangent is the single one bit for bit, all round the
    /// circle, at octant edges and axes, signed zeros, tiny and huge
    /// lengths and NaN.
    #[test]
    fn atan2_pair_equals_atan2() {
        let mut pairs = vec![
            (0.0f32, 1.0f32),
            (-0.0, 1.0),
            (0.0, -1.0),
            (-0.0, -0.0),
            (1.0, 0.0),
            (-1e-30, 1e30),
            (1.0, 1.0),
            (-1.0, -1.0),
            (f32::NAN, 1.0),
            (1.0, f32::NAN),
            (f32::INFINITY, 1.0),
        ];
        for k in 0..20_000 {
            let angle = -std::f32::consts::PI + 2.0 * std::f32::consts::PI * (k as f32 + 0.5) / 2e4;
            for len in [1e-20f32, 1.0, 1e20] {
                pairs.push((angle.sin() * len, angle.cos() * len));
            }
        }
        for w in pairs.windows(2) {
            let [(y0, x0), (y1, x1)] = [w[0], w[1]];
            let got = atan2_pair([y0, y1], [x0, x1]);
            for (g, (y, x)) in got.iter().zip([(y0, x0), (y1, x1)]) {
                assert_eq!(g.to_bits(), atan2(y, x).to_bits(), "atan2({y}, {x})");
            }
        }
    }

    /// The f64 form agrees with the f32 one within a few ulps where both
    /// apply, and keeps the angle where f32 would overflow.
    #[test]
    fn atan2_f64_matches_atan2() {
        for k in 0..10_000 {
            let angle = -PI + 2.0 * PI * (k as f32 + 0.5) / 1e4;
            let (y, x) = (angle.sin(), angle.cos());
            let wide = atan2_f64(f64::from(y), f64::from(x));
            assert!((wide - atan2(y, x)).abs() <= 5e-7, "{y} {x}");
            let huge = atan2_f64(f64::from(y) * 1e300, f64::from(x) * 1e300);
            assert_eq!(huge.to_bits(), wide.to_bits(), "{y} {x}");
        }
        assert_eq!(atan2_f64(0.0, 0.0), 0.0);
    }

    /// Within 3·10⁻⁷ rad of the f64 angle all round the circle (the
    /// polynomial's 10⁻⁷ plus rounding: an f32 ulp near π is 2.4·10⁻⁷),
    /// at octant edges and axes, and for lengths from tiny to huge.
    #[test]
    fn atan2_matches_f64() {
        let mut worst = 0.0f64;
        for k in 0..100_000 {
            let angle = -std::f64::consts::PI + 2.0 * std::f64::consts::PI * (k as f64 + 0.5) / 1e5;
            for len in [1e-20f64, 1e-3, 1.0, 1e20] {
                let (y, x) = ((angle.sin() * len) as f32, (angle.cos() * len) as f32);
                let expected = f64::from(y).atan2(f64::from(x));
                worst = worst.max((f64::from(atan2(y, x)) - expected).abs());
            }
        }
        assert!(worst < 3e-7, "largest error {worst}");
        for (y, x, expected) in [
            (0.0f32, 1.0f32, 0.0f32),
            (1.0, 0.0, FRAC_PI_2),
            (0.0, -1.0, PI),
            (-1.0, 0.0, -FRAC_PI_2),
            (1.0, 1.0, FRAC_PI_4),
            (-1.0, -1.0, -3.0 * FRAC_PI_4),
            (0.0, 0.0, 0.0),
        ] {
            assert!(
                (atan2(y, x) - expected).abs() < 2e-7,
                "atan2({y}, {x}) = {}",
                atan2(y, x)
            );
        }
    }
}
