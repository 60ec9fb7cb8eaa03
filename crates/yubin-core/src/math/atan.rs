//! An arctangent without a libm call, for the per-ray angle lookups
//! (environment maps' latitude–longitude coordinates, the sphere's and
//! other round shapes' φ and θ): one reduction to
//! |t| ≤ tan(π/8) and Moshier's Cephes `atanf` polynomial, whose error
//! there is about 10⁻⁷ (S. L. Moshier, *Methods and Programs for
//! Mathematical Functions*, 1989), with the octant folded back by
//! selects rather than branches: which octant a ray's direction falls in
//! is a coin flip per ray.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// tan(π/8).
const TAN_PI_8: f32 = 0.414_213_57;

/// atan(a) for a in [0, 1].
#[inline]
fn atan_unit(a: f32) -> f32 {
    let reduce = a > TAN_PI_8;
    let t = if reduce { (a - 1.0) / (a + 1.0) } else { a };
    let z = t * t;
    let p =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t
            + t;
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
    let r = atan_unit(a);
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    if y < 0.0 {
        -r
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
