use glam::{Affine3A, Mat3, Mat4, Vec3};

/// An affine transform with its inverse and the normal matrix, so that
/// points, vectors and normals all transform without inverting per ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// The forward map.
    pub m: Affine3A,
    /// Its inverse.
    pub inv: Affine3A,
    /// Inverse transpose of the linear part (for normals).
    pub normal: Mat3,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Self = Self {
        m: Affine3A::IDENTITY,
        inv: Affine3A::IDENTITY,
        normal: Mat3::IDENTITY,
    };

    /// From an affine map; `None` when it cannot be inverted.
    pub fn new(m: Affine3A) -> Option<Self> {
        let det = m.matrix3.determinant();
        if !det.is_finite() || det.abs() < 1e-30 {
            return None;
        }
        let inv = m.inverse();
        Some(Self {
            m,
            inv,
            normal: Mat3::from(inv.matrix3).transpose(),
        })
    }

    /// From a 4×4 matrix whose last row is (0, 0, 0, 1) (projective parts
    /// are dropped).
    pub fn from_mat4(m: Mat4) -> Option<Self> {
        Self::new(Affine3A::from_mat4(m))
    }

    /// Maps a point.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.m.transform_point3(p)
    }

    /// Maps a vector.
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.m.transform_vector3(v)
    }

    /// Maps a normal (not normalized).
    #[inline]
    pub fn normal(&self, n: Vec3) -> Vec3 {
        self.normal * n
    }

    /// True when the linear part flips orientation (negative determinant).
    pub fn swaps_handedness(&self) -> bool {
        self.m.matrix3.determinant() < 0.0
    }

    /// The inverse map.
    pub fn inverse(&self) -> Transform {
        Transform {
            m: self.inv,
            inv: self.m,
            normal: Mat3::from(self.m.matrix3).transpose(),
        }
    }

    /// `self` applied after `first`.
    pub fn after(&self, first: &Transform) -> Transform {
        let m = self.m * first.m;
        let inv = first.inv * self.inv;
        Transform {
            m,
            inv,
            normal: Mat3::from(inv.matrix3).transpose(),
        }
    }
}
