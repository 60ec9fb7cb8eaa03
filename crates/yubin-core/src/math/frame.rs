use glam::Vec3;

/// Builds two unit vectors perpendicular to unit `n` and to each other
/// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
#[inline]
pub fn coordinate_system(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// An orthonormal frame `(s, t, n)`; local coordinates have `n` as +z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// Normal.
    pub n: Vec3,
}

impl Frame {
    /// A frame around unit normal `n` with arbitrary tangents.
    pub fn from_normal(n: Vec3) -> Self {
        let (s, t) = coordinate_system(n);
        Self { s, t, n }
    }

    /// A frame around unit `n` whose first tangent follows `dpdu` where it
    /// can (Gram–Schmidt), falling back to arbitrary tangents.
    pub fn from_normal_and_tangent(n: Vec3, dpdu: Vec3) -> Self {
        let s = dpdu - n * n.dot(dpdu);
        let len2 = s.length_squared();
        if len2 > 1e-12 && len2.is_finite() {
            let s = s / len2.sqrt();
            Self {
                s,
                t: n.cross(s),
                n,
            }
        } else {
            Self::from_normal(n)
        }
    }

    /// World → local.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.2).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5);
            let v = Vec3::new(0.1, 0.7, -0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }
}
