//! Fresnel reflectance of smooth interfaces and the mirror and refraction
//! directions, shared by every BSDF with a specular or microfacet lobe.
//!
//! Conventions (Mitsuba 3's):
//! - Directions are in the local frame (+z the normal) and point away from
//!   the surface; `cos_theta_i` is the cosine of the incident direction
//!   with the normal, negative when it arrives from inside.
//! - `eta` is the relative index of refraction interior / exterior.
//!
//! References: pbrt-v4 §9.3 (the Fresnel equations, §9.3.6 conductors),
//! Walter et al. 2007, "Microfacet Models for Refraction through Rough
//! Surfaces" (refraction about a microfacet normal), and the closed-form
//! reflectance of an absorbing medium (Born & Wolf, *Principles of
//! Optics*, on metals) as written out by Lagarde 2013, "Memo on Fresnel
//! equations".

use crate::Rgb;
use glam::Vec3;

/// Unpolarized Fresnel reflectance of a dielectric interface.
///
/// `cos_theta_i` is the cosine of the incident angle (negative when the
/// direction is inside), `eta` the interior / exterior index ratio.
/// Returns `(F, cos_theta_t, eta_it, eta_ti)`: the reflectance, the cosine
/// of the refracted direction (of the opposite sign to `cos_theta_i`, 0 on
/// total internal reflection, where `F` = 1), and the relative indices
/// `eta_it` = η_t/η_i (transmitted over incident side, so `eta` from
/// outside and 1/`eta` from inside) and `eta_ti` = η_i/η_t, its inverse,
/// which scales the tangential part of the refracted direction.
#[inline]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let ci = cos_theta_i.abs();
    // Snell's law: sin²θt = (η_i/η_t)² sin²θi.
    let cos2_t = 1.0 - eta_ti * eta_ti * (1.0 - ci * ci).max(0.0);
    if cos2_t <= 0.0 {
        // Total internal reflection (cos2_t == 0 is its grazing limit,
        // where the equations below also give 1).
        return (1.0, 0.0, eta_it, eta_ti);
    }
    let ct = cos2_t.sqrt();
    let f = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        // Amplitude ratios for light polarized perpendicular (s) and
        // parallel (p) to the plane of incidence, with indices normalized
        // by η_i (pbrt-v4 eq. 9.4, 9.5).
        let r_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let r_p = (eta_it * ci - ct) / (eta_it * ci + ct);
        0.5 * (r_s * r_s + r_p * r_p)
    };
    let cos_theta_t = if outside { -ct } else { ct };
    (f, cos_theta_t, eta_it, eta_ti)
}

/// Unpolarized Fresnel reflectance of a conductor with complex index of
/// refraction η + ik (relative to the exterior), per colour channel.
/// `cos_theta_i` is taken in absolute value.
///
/// With a² + b² = √((η² − k² − sin²θ)² + 4η²k²) and
/// a = √((a² + b² + η² − k² − sin²θ) / 2), the s- and p-reflectances are
/// R_s = (a² + b² − 2a cos θ + cos²θ) / (a² + b² + 2a cos θ + cos²θ) and
/// R_p = R_s (cos²θ (a² + b²) − 2a cos θ sin²θ + sin⁴θ) /
/// (cos²θ (a² + b²) + 2a cos θ sin²θ + sin⁴θ) (Lagarde 2013). η = 0,
/// k = 1 gives a = 0 and R = 1 at every angle.
#[inline]
pub fn fresnel_conductor(cos_theta_i: f32, eta: Rgb, k: Rgb) -> Rgb {
    let c = cos_theta_i.abs().min(1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let t0 = eta * eta - k * k - Rgb::splat(s2);
    let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).max(Rgb::ZERO);
    let a2b2 = Rgb::new(a2b2.x.sqrt(), a2b2.y.sqrt(), a2b2.z.sqrt());
    let a = (0.5 * (a2b2 + t0)).max(Rgb::ZERO);
    let a = Rgb::new(a.x.sqrt(), a.y.sqrt(), a.z.sqrt());
    let t1 = a2b2 + Rgb::splat(c2);
    let t2 = 2.0 * c * a;
    let r_s = (t1 - t2) / (t1 + t2).max(Rgb::splat(f32::MIN_POSITIVE));
    let t3 = a2b2 * c2 + Rgb::splat(s4);
    let t4 = t2 * s2;
    let r_p = r_s * (t3 - t4) / (t3 + t4).max(Rgb::splat(f32::MIN_POSITIVE));
    (0.5 * (r_s + r_p)).clamp(Rgb::ZERO, Rgb::ONE)
}

/// Mirror reflection of `wi` about +z.
#[inline]
pub fn reflect(wi: Vec3) -> Vec3 {
    Vec3::new(-wi.x, -wi.y, wi.z)
}

/// Refraction of `wi` through the plane z = 0, given the `cos_theta_t` and
/// `eta_ti` that [`fresnel_dielectric`] returned for `wi.z`.
#[inline]
pub fn refract(wi: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    Vec3::new(-eta_ti * wi.x, -eta_ti * wi.y, cos_theta_t)
}

/// Mirror reflection of `wi` about the unit normal `m`.
#[inline]
pub fn reflect_m(wi: Vec3, m: Vec3) -> Vec3 {
    2.0 * wi.dot(m) * m - wi
}

/// Refraction of `wi` through a facet with unit normal `m`, given the
/// `cos_theta_t` and `eta_ti` that [`fresnel_dielectric`] returned for
/// `wi · m` (Walter et al. 2007, eq. 40).
#[inline]
pub fn refract_m(wi: Vec3, m: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    m * (wi.dot(m) * eta_ti + cos_theta_t) - wi * eta_ti
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-6)
    }

    #[test]
    fn normal_incidence_dielectric() {
        for eta in [1.2f32, 1.5, 2.4, 0.7] {
            let (f, ct, eta_it, eta_ti) = fresnel_dielectric(1.0, eta);
            let expected = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!(close(f, expected, 1e-5), "η={eta}: {f} vs {expected}");
            assert!(close(ct, -1.0, 1e-6));
            assert_eq!((eta_it, eta_ti), (eta, 1.0 / eta));
            // From inside the same interface at normal incidence.
            let (f2, ct2, eta_it2, eta_ti2) = fresnel_dielectric(-1.0, eta);
            assert!(close(f2, expected, 1e-5));
            assert!(close(ct2, 1.0, 1e-6));
            assert_eq!((eta_it2, eta_ti2), (1.0 / eta, eta));
        }
    }

    #[test]
    fn index_matched_and_grazing() {
        let (f, ct, _, _) = fresnel_dielectric(0.3, 1.0);
        assert_eq!(f, 0.0);
        assert!(close(ct, -0.3, 1e-6));
        assert_eq!(fresnel_dielectric(0.0, 1.5).0, 1.0);
    }

    #[test]
    fn total_internal_reflection() {
        let eta = 1.5f32;
        // Critical angle from inside: sin θc = 1/η.
        let cos_c = (1.0 - 1.0 / (eta * eta)).sqrt();
        let (f, ct, _, _) = fresnel_dielectric(-(cos_c - 0.01), eta);
        assert_eq!((f, ct), (1.0, 0.0));
        let (f, ct, _, _) = fresnel_dielectric(-(cos_c + 0.01), eta);
        assert!(f < 1.0 && ct > 0.0, "{f} {ct}");
    }

    #[test]
    fn reciprocal_at_refracted_angle() {
        for eta in [1.33f32, 1.5, 2.0] {
            for ci in [0.05f32, 0.2, 0.5, 0.8, 0.99] {
                let (f, ct, _, eta_ti) = fresnel_dielectric(ci, eta);
                let (f_back, ct_back, _, _) = fresnel_dielectric(ct, eta);
                assert!(close(f, f_back, 1e-4), "η={eta} cos={ci}: {f} vs {f_back}");
                assert!(close(ct_back, ci, 1e-4));
                // The same with the inverse ratio seen from outside.
                let (f_inv, _, _, _) = fresnel_dielectric(-ct, 1.0 / eta);
                assert!(close(f, f_inv, 1e-4));
                // Refracted direction: unit, below the surface, Snell's law.
                let wi = Vec3::new((1.0 - ci * ci).sqrt(), 0.0, ci);
                let wt = refract(wi, ct, eta_ti);
                assert!(close(wt.length(), 1.0, 1e-5));
                assert!(close(wt.x.abs() * eta, wi.x, 1e-4) && wt.z < 0.0);
            }
        }
    }

    #[test]
    fn conductor_without_absorption_is_a_dielectric() {
        for eta in [1.3f32, 1.7, 2.5] {
            for ci in [0.02f32, 0.3, 0.7, 1.0] {
                let fc = fresnel_conductor(ci, Rgb::splat(eta), Rgb::ZERO);
                let fd = fresnel_dielectric(ci, eta).0;
                assert!(close(fc.x, fd, 2e-4), "η={eta} cos={ci}: {fc} vs {fd}");
            }
        }
    }

    #[test]
    fn conductor_known_values() {
        // Gold-like (η, k) per channel; at normal incidence
        // R = ((η − 1)² + k²) / ((η + 1)² + k²).
        let eta = Rgb::new(0.143, 0.374, 1.442);
        let k = Rgb::new(3.983, 2.385, 1.603);
        let r = fresnel_conductor(1.0, eta, k);
        let expected = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
        assert!(
            (r - expected).abs().max_element() < 1e-5,
            "{r} vs {expected}"
        );
        // Reflectance rises to one at grazing incidence.
        assert!(
            (fresnel_conductor(0.0, eta, k) - Rgb::ONE)
                .abs()
                .max_element()
                < 1e-5
        );
        // The perfect mirror of `material = "none"`.
        for ci in [0.0f32, 0.1, 0.5, 1.0] {
            assert_eq!(fresnel_conductor(ci, Rgb::ZERO, Rgb::ONE), Rgb::ONE);
        }
    }

    /// Against Mitsuba 3.9.1 (`scalar_rgb`): `mi.fresnel(0.3, 1.5)`,
    /// `mi.fresnel(-0.9, 1.5)`, `mi.fresnel(-0.3, 1.5)` and
    /// `mi.fresnel_conductor(0.3, dr.scalar.Complex2f(0.143, 3.983))`.
    #[test]
    fn matches_mitsuba() {
        let cases = [
            ((0.3, 1.5), (0.207_756_34, -0.771_722_4, 1.5, 0.666_666_7)),
            ((-0.9, 1.5), (0.046_332_64, 0.756_637_3, 0.666_666_7, 1.5)),
            ((-0.3, 1.5), (1.0, 0.0, 0.666_666_7, 1.5)),
        ];
        for ((ci, eta), (f, ct, eta_it, eta_ti)) in cases {
            let got = fresnel_dielectric(ci, eta);
            assert!(
                close(got.0, f, 1e-5)
                    && (got.1 - ct).abs() < 1e-6
                    && close(got.2, eta_it, 1e-6)
                    && close(got.3, eta_ti, 1e-6),
                "fresnel({ci}, {eta}) = {got:?}"
            );
        }
        let r = fresnel_conductor(0.3, Rgb::splat(0.143), Rgb::splat(3.983));
        assert!(close(r.x, 0.959_035_46, 1e-5), "{r}");
    }

    #[test]
    fn reflection_about_a_normal() {
        let wi = Vec3::new(0.3, -0.4, 0.866).normalize();
        assert_eq!(reflect(wi), reflect_m(wi, Vec3::Z));
        let m = Vec3::new(0.2, 0.1, 0.97).normalize();
        let wo = reflect_m(wi, m);
        assert!(close(wo.length(), 1.0, 1e-5));
        assert!((wi + wo).normalize().distance(m) < 1e-5);
        // Refraction about m agrees with refraction about z in m's frame.
        let (_, ct, _, eta_ti) = fresnel_dielectric(wi.dot(Vec3::Z), 1.5);
        assert!(refract_m(wi, Vec3::Z, ct, eta_ti).distance(refract(wi, ct, eta_ti)) < 1e-6);
    }
}
