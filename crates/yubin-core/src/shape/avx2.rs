//! The eight-lane shape tests of packet traversal ([`Shape::intersect_packet`])
//! with each step one AVX instruction, for traversal compiled for AVX2 and
//! chosen at run time (`scene/packet.rs`). `wide` picks its form by the
//! build's flags, so in code compiled for AVX2 at run time its eight
//! lanes are still two SSE halves; these are the same operations in the
//! same order (multiplications and additions never fused, `-x` as
//! `0 - x`, blends by mask), so the hits are the portable tests' bit for
//! bit (`avx2_shape_tests_equal_portable_ones`). A build for AVX2
//! (`target-cpu`) has `wide` in AVX registers already and uses the
//! portable tests.

use super::cube::face_code;
use super::{Cube, Disk, Rectangle, Shape, Sphere};
use crate::math::{RayPacket, Transform};
use std::arch::x86_64::{
    __m256, _mm256_add_ps, _mm256_and_ps, _mm256_andnot_ps, _mm256_blendv_ps, _mm256_cmp_ps,
    _mm256_div_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_set1_ps,
    _mm256_setzero_ps, _mm256_sqrt_ps, _mm256_sub_ps, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ,
    _CMP_NEQ_UQ,
};
use wide::f32x8;

/// A lane vector as an AVX register.
#[inline(always)]
fn reg(v: f32x8) -> __m256 {
    bytemuck::cast(v)
}

/// An AVX register as a lane vector.
#[inline(always)]
fn lanes(v: __m256) -> f32x8 {
    bytemuck::cast(v)
}

/// [`Shape::intersect_packet`] in AVX registers.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn shape_packet_avx2(
    shape: &Shape,
    rays: &RayPacket,
    t_max: f32x8,
) -> Option<(u32, f32x8, [f32x8; 2])> {
    match shape {
        Shape::Sphere(s) => {
            let (hit, t) = sphere(s, rays, reg(t_max));
            Some((hit, lanes(t), [f32x8::ZERO; 2]))
        }
        Shape::Rectangle(r) => Some(rectangle(r, rays, reg(t_max))),
        Shape::Disk(d) => Some(disk(d, rays, reg(t_max))),
        Shape::Cube(c) => Some(cube(c, rays, reg(t_max))),
        Shape::Mesh(_)
        | Shape::Cylinder(_)
        | Shape::Sdf(_)
        | Shape::SdfGrid(_)
        | Shape::Ellipsoids(_)
        | Shape::EllipsoidsMesh(_)
        | Shape::LinearCurve(_)
        | Shape::BSplineCurve(_) => None,
    }
}

/// The lanes of `rays` that `shape` blocks within `t_max` (`None` for
/// shapes without an eight-lane test): [`shape_packet_avx2`]'s hits, for
/// shadow rays, which need no distance.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn shape_blocks_avx2(shape: &Shape, rays: &RayPacket, t_max: f32x8) -> Option<u32> {
    Some(match shape {
        Shape::Sphere(s) => sphere(s, rays, reg(t_max)).0,
        Shape::Rectangle(r) => rectangle(r, rays, reg(t_max)).0,
        Shape::Disk(d) => disk(d, rays, reg(t_max)).0,
        Shape::Cube(c) => cube(c, rays, reg(t_max)).0,
        Shape::Mesh(_)
        | Shape::Cylinder(_)
        | Shape::Sdf(_)
        | Shape::SdfGrid(_)
        | Shape::Ellipsoids(_)
        | Shape::EllipsoidsMesh(_)
        | Shape::LinearCurve(_)
        | Shape::BSplineCurve(_) => return None,
    })
}

/// [`Sphere::intersect_packet`].
#[target_feature(enable = "avx2")]
#[inline]
fn sphere(s: &Sphere, rays: &RayPacket, t_max: __m256) -> (u32, __m256) {
    let [dx, dy, dz] = rays.d.map(reg);
    let f: [__m256; 3] =
        std::array::from_fn(|a| _mm256_sub_ps(reg(rays.o[a]), _mm256_set1_ps(s.center[a])));
    let [fx, fy, fz] = f;
    let dot = |a: [__m256; 3], b: [__m256; 3]| {
        _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])),
            _mm256_mul_ps(a[2], b[2]),
        )
    };
    let d = [dx, dy, dz];
    let zero = _mm256_setzero_ps();
    let a = dot(d, d);
    let b = _mm256_sub_ps(zero, dot(f, d));
    let s_ = _mm256_div_ps(b, a);
    let l: [__m256; 3] = std::array::from_fn(|i| _mm256_add_ps(f[i], _mm256_mul_ps(s_, d[i])));
    let r2 = _mm256_set1_ps(s.radius * s.radius);
    let disc = _mm256_mul_ps(a, _mm256_sub_ps(r2, dot(l, l)));
    let sign = _mm256_set1_ps(-0.0);
    // copysign as `wide` spells it: magnitude bits, then the sign bit.
    let root = _mm256_sqrt_ps(disc);
    let copysign = _mm256_or_ps(_mm256_andnot_ps(sign, root), _mm256_and_ps(b, sign));
    let q = _mm256_add_ps(b, copysign);
    let t0 = _mm256_div_ps(q, a);
    let far = _mm256_div_ps(_mm256_sub_ps(dot([fx, fy, fz], [fx, fy, fz]), r2), q);
    let t1 = _mm256_blendv_ps(t0, far, _mm256_cmp_ps::<_CMP_NEQ_UQ>(q, zero));
    let swap = _mm256_cmp_ps::<_CMP_GT_OQ>(t0, t1);
    let (t0, t1) = (
        _mm256_blendv_ps(t0, t1, swap),
        _mm256_blendv_ps(t1, t0, swap),
    );
    let t_min = reg(rays.t_min);
    let t = _mm256_blendv_ps(t1, t0, _mm256_cmp_ps::<_CMP_GT_OQ>(t0, t_min));
    let bits = |m: __m256| _mm256_movemask_ps(m) as u32;
    let hit = !bits(_mm256_cmp_ps::<_CMP_LT_OQ>(disc, zero))
        & bits(_mm256_cmp_ps::<_CMP_GT_OQ>(t, t_min))
        & bits(_mm256_cmp_ps::<_CMP_LT_OQ>(t, t_max));
    (hit, t)
}

/// [`super::intersect_local_plane_packet`]: the lanes that meet the
/// object-space plane z = 0 within their intervals, the distances and
/// the object-space x and y.
#[target_feature(enable = "avx2")]
#[inline]
fn local_plane(
    to_world: &Transform,
    rays: &RayPacket,
    t_max: __m256,
) -> (u32, __m256, [__m256; 2]) {
    let m = &to_world.inv;
    let columns = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
    let o: [__m256; 3] = std::array::from_fn(|i| {
        _mm256_add_ps(
            linear(columns, i, &rays.o),
            _mm256_set1_ps(m.translation[i]),
        )
    });
    let d: [__m256; 3] = std::array::from_fn(|i| linear(columns, i, &rays.d));
    let t = _mm256_div_ps(_mm256_sub_ps(_mm256_setzero_ps(), o[2]), d[2]);
    let hit = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GT_OQ>(t, reg(rays.t_min)),
        _mm256_cmp_ps::<_CMP_LT_OQ>(t, t_max),
    );
    let at = |i: usize| _mm256_add_ps(o[i], _mm256_mul_ps(t, d[i]));
    (_mm256_movemask_ps(hit) as u32, t, [at(0), at(1)])
}

/// Row `i` of the 3×3 matrix with these columns applied to the lanes `v`.
/// A function, not a closure: the closure was compiled out of line.
#[target_feature(enable = "avx2")]
#[inline]
fn linear(columns: [glam::Vec3A; 3], i: usize, v: &[f32x8; 3]) -> __m256 {
    let [cx, cy, cz] = columns.map(|c| _mm256_set1_ps(c[i]));
    _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(cx, reg(v[0])), _mm256_mul_ps(cy, reg(v[1]))),
        _mm256_mul_ps(cz, reg(v[2])),
    )
}

/// [`Rectangle::intersect_packet`].
#[target_feature(enable = "avx2")]
#[inline]
fn rectangle(r: &Rectangle, rays: &RayPacket, t_max: __m256) -> (u32, f32x8, [f32x8; 2]) {
    let (hit, t, [x, y]) = local_plane(&r.to_world, rays, t_max);
    let (one, sign) = (_mm256_set1_ps(1.0), _mm256_set1_ps(-0.0));
    let within = |v: __m256| _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_andnot_ps(sign, v), one);
    let inside = _mm256_movemask_ps(_mm256_and_ps(within(x), within(y))) as u32;
    (hit & inside, lanes(t), [lanes(x), lanes(y)])
}

/// [`Disk::intersect_packet`].
#[target_feature(enable = "avx2")]
#[inline]
fn disk(d: &Disk, rays: &RayPacket, t_max: __m256) -> (u32, f32x8, [f32x8; 2]) {
    let (hit, t, [x, y]) = local_plane(&d.to_world, rays, t_max);
    let r2 = _mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y));
    let inside = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(r2, _mm256_set1_ps(1.0))) as u32;
    (hit & inside, lanes(t), [lanes(x), lanes(y)])
}

/// [`Cube::intersect_packet`]: the slabs' entry and exit distances with
/// the faces crossed there, the first axis' taken as they are.
#[target_feature(enable = "avx2")]
#[inline]
fn cube(c: &Cube, rays: &RayPacket, t_max: __m256) -> (u32, f32x8, [f32x8; 2]) {
    let m = &c.to_world.inv;
    let columns = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
    let zero = _mm256_setzero_ps();
    let one = _mm256_set1_ps(1.0);
    let minus_one = _mm256_sub_ps(zero, one);
    let (mut near, mut near_face, mut far, mut far_face) = (zero, zero, zero, zero);
    for i in 0..3 {
        let o = _mm256_add_ps(
            linear(columns, i, &rays.o),
            _mm256_set1_ps(m.translation[i]),
        );
        let inv_d = _mm256_div_ps(one, linear(columns, i, &rays.d));
        let t0 = _mm256_mul_ps(_mm256_sub_ps(minus_one, o), inv_d);
        let t1 = _mm256_mul_ps(_mm256_sub_ps(one, o), inv_d);
        let lo = _mm256_set1_ps(face_code(i, false));
        let hi = _mm256_set1_ps(face_code(i, true));
        let ordered = _mm256_cmp_ps::<_CMP_LT_OQ>(t0, t1);
        let (n, n_face) = (
            _mm256_blendv_ps(t1, t0, ordered),
            _mm256_blendv_ps(hi, lo, ordered),
        );
        let (f, f_face) = (
            _mm256_blendv_ps(t0, t1, ordered),
            _mm256_blendv_ps(lo, hi, ordered),
        );
        if i == 0 {
            (near, near_face, far, far_face) = (n, n_face, f, f_face);
        } else {
            let keep = _mm256_cmp_ps::<_CMP_GT_OQ>(near, n);
            near = _mm256_blendv_ps(n, near, keep);
            near_face = _mm256_blendv_ps(n_face, near_face, keep);
            let keep = _mm256_cmp_ps::<_CMP_LT_OQ>(far, f);
            far = _mm256_blendv_ps(f, far, keep);
            far_face = _mm256_blendv_ps(f_face, far_face, keep);
        }
    }
    let t_min = reg(rays.t_min);
    let entering = _mm256_cmp_ps::<_CMP_GT_OQ>(near, t_min);
    let t = _mm256_blendv_ps(far, near, entering);
    let face = _mm256_blendv_ps(far_face, near_face, entering);
    let bits = |m: __m256| _mm256_movemask_ps(m) as u32;
    let hit = bits(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far))
        & bits(_mm256_cmp_ps::<_CMP_GT_OQ>(t, t_min))
        & bits(_mm256_cmp_ps::<_CMP_LT_OQ>(t, t_max));
    (hit, lanes(t), [lanes(face), f32x8::ZERO])
}
