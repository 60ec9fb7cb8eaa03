//! `cube`: the axis-aligned cube [-1, 1]³ of object space, with the
//! per-face normals and uvs of Mitsuba 3's 12-triangle cube mesh.
//!
//! | parameter      | type      | default  | meaning                         |
//! |----------------|-----------|----------|---------------------------------|
//! | `to_world`     | transform | identity | placement (any affine map)      |
//! | `flip_normals` | boolean   | false    | normals point inward            |
//!
//! ```xml
//! <shape type="cube"><transform name="to_world"><scale value="0.5"/></transform></shape>
//! ```
//!
//! Each face's uv spans [0, 1]², laid out as on Mitsuba 3's cube mesh
//! (read from `mitsuba.load_dict({"type": "cube"})`, 3.9.1): u follows
//! +y and v −z on the +x face, u +y and v +z on −x, u −x and v −z on
//! +y, u +z and v +x on −y, u +y and v +x on +z, u −y and v +x on −z. A ray is
//! intersected with the whole cube at once by the slab method (Kay &
//! Kajiya 1986) in object space, where a mesh would test up to twelve
//! triangles; rays starting inside leave through the far face. Area
//! sampling picks a face by its area, then a point uniformly on it.
//!
//! An emitting cube, and one whose BSDF reads MikkTSpace tangents, is
//! built as the 12-triangle mesh instead ([`Cube::mesh`]): the light
//! hierarchy bounds a mesh's triangles one by one, and tangents are a
//! mesh's.

use super::{make_interaction_in_frame, PositionSample, PrimHit, ShapeModel, TriangleMesh};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Frame, Ray, RayPacket, Transform};
use crate::params::{ParamError, Params};
use glam::{BVec3A, Vec2, Vec3, Vec3A};
use wide::{f32x8, CmpGt, CmpLe, CmpLt};

/// The transformed cube [-1, 1]³.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cube {
    /// Object to world.
    pub(crate) to_world: Transform,
    /// Normals point inward.
    pub(crate) flip_normals: bool,
    /// Per face, in [`face_code`] order, what its interactions read.
    faces: [CubeFace; 6],
    /// Per axis, the area of one of its two faces.
    face_areas: [f32; 3],
    area: f32,
    inv_area: f32,
}

/// One face of a cube: its shading frame, dp/du and dp/dv.
#[derive(Clone, Copy, Debug, PartialEq)]
struct CubeFace {
    frame: Frame,
    dpdu: Vec3,
    dpdv: Vec3,
}

/// Per face (in [`face_code`] order), in object space: which coordinate
/// is its axis, that coordinate (±1), and the axes u and v follow
/// (Mitsuba 3's cube mesh; see the module docs).
const FACE_AXES: [([bool; 3], f32, Vec3, Vec3); 6] = [
    ([true, false, false], -1.0, Vec3::Y, Vec3::Z),
    ([false, true, false], -1.0, Vec3::Z, Vec3::X),
    ([false, false, true], -1.0, Vec3::NEG_Y, Vec3::X),
    ([true, false, false], 1.0, Vec3::Y, Vec3::NEG_Z),
    ([false, true, false], 1.0, Vec3::NEG_X, Vec3::NEG_Z),
    ([false, false, true], 1.0, Vec3::Y, Vec3::X),
];

/// How far samples stay from a face's edges, in uv.
const EDGE_INSET: f32 = 1e-6;

/// The next axis after `a`, cyclically.
#[inline]
fn next(a: usize) -> usize {
    (a + 1) % 3
}

impl Cube {
    /// The cube placed by `to_world`, normals inward if `flip_normals`.
    pub fn new(to_world: Transform, flip_normals: bool) -> Self {
        let column = |a: usize| to_world.vector(Vec3::AXES[a]);
        let face_areas: [f32; 3] =
            std::array::from_fn(|a| 4.0 * column(next(a)).cross(column(next(next(a)))).length());
        let area = 2.0 * face_areas.iter().sum::<f32>();
        let faces = std::array::from_fn(|code| {
            let (axis, positive) = face_of_code(code as f32);
            let (_, side, u_axis, v_axis) = FACE_AXES[code];
            let dpdu = 2.0 * to_world.vector(u_axis);
            let dpdv = 2.0 * to_world.vector(v_axis);
            let n = super::world_normal(&to_world, Vec3::AXES[axis] * side, flip_normals);
            debug_assert_eq!(positive, side > 0.0);
            CubeFace {
                frame: Frame::from_normal_and_tangent(n, dpdu),
                dpdu,
                dpdv,
            }
        });
        Self {
            to_world,
            flip_normals,
            faces,
            face_areas,
            area,
            inv_area: 1.0 / area,
        }
    }

    /// Builds the cube from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let (to_world, flip_normals) = super::placement(p)?;
        Ok(Self::new(to_world, flip_normals))
    }

    /// The same cube as a 12-triangle mesh in world space.
    pub fn mesh(&self) -> TriangleMesh {
        let mut mesh = cube_mesh_with(self.flip_normals);
        mesh.transform(&self.to_world);
        mesh
    }

    /// The face with outward normal `sign` e_`axis`.
    #[inline]
    fn face(&self, axis: usize, positive: bool) -> &CubeFace {
        &self.faces[face_code(axis, positive) as usize]
    }

    /// The ray's entry and exit distances through the cube's slabs, each
    /// with the face it crosses there ([`face_code`]), in the order of
    /// operations [`Cube::intersect_packet`] repeats lane by lane.
    /// Selections rather than `min`/`max`, so that a NaN (a ray in a
    /// face's plane) picks the same side in both.
    #[inline]
    fn slabs(&self, ray: &Ray) -> [(f32, f32); 2] {
        let o = self.to_world.inv.transform_point3a(ray.o.into());
        let d = self.to_world.inv.transform_vector3a(ray.d.into());
        let inv_d = Vec3A::ONE / d;
        let t0 = (Vec3A::NEG_ONE - o) * inv_d;
        let t1 = (Vec3A::ONE - o) * inv_d;
        let ordered = t0.cmplt(t1);
        let (lo, hi) = (Vec3A::new(0.0, 1.0, 2.0), Vec3A::new(3.0, 4.0, 5.0));
        let near = Vec3A::select(ordered, t0, t1);
        let near_face = Vec3A::select(ordered, lo, hi);
        let far = Vec3A::select(ordered, t1, t0);
        let far_face = Vec3A::select(ordered, hi, lo);
        let (mut entry, mut exit) = ((near.x, near_face.x), (far.x, far_face.x));
        for i in 1..3 {
            entry = if entry.0 > near[i] {
                entry
            } else {
                (near[i], near_face[i])
            };
            exit = if exit.0 < far[i] {
                exit
            } else {
                (far[i], far_face[i])
            };
        }
        [entry, exit]
    }

    /// [`ShapeModel::intersect`] for the eight rays of `rays` at once, each
    /// within its lane of `t_max`: the lanes that hit, their distances and
    /// [`PrimHit::uv`] (the face), the single-ray test's bit for bit.
    #[inline]
    pub(crate) fn intersect_packet(
        &self,
        rays: &RayPacket,
        t_max: f32x8,
    ) -> (u32, f32x8, [f32x8; 2]) {
        let m = &self.to_world.inv;
        let [cx, cy, cz] = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
        let linear = |v: &[f32x8; 3], i: usize| {
            let s = |c: glam::Vec3A| f32x8::splat(c[i]);
            s(cx) * v[0] + s(cy) * v[1] + s(cz) * v[2]
        };
        let one = f32x8::ONE;
        let mut near = (f32x8::ZERO, f32x8::ZERO);
        let mut far = near;
        for i in 0..3 {
            let o = linear(&rays.o, i) + f32x8::splat(m.translation[i]);
            let inv_d = one / linear(&rays.d, i);
            let t0 = (-one - o) * inv_d;
            let t1 = (one - o) * inv_d;
            let (lo, hi) = (
                f32x8::splat(face_code(i, false)),
                f32x8::splat(face_code(i, true)),
            );
            let ordered = t0.cmp_lt(t1);
            let n = (ordered.blend(t0, t1), ordered.blend(lo, hi));
            let f = (ordered.blend(t1, t0), ordered.blend(hi, lo));
            if i == 0 {
                (near, far) = (n, f);
            } else {
                let keep = near.0.cmp_gt(n.0);
                near = (keep.blend(near.0, n.0), keep.blend(near.1, n.1));
                let keep = far.0.cmp_lt(f.0);
                far = (keep.blend(far.0, f.0), keep.blend(far.1, f.1));
            }
        }
        let entering = near.0.cmp_gt(rays.t_min);
        let t = entering.blend(near.0, far.0);
        let face = entering.blend(near.1, far.1);
        let hit = near.0.cmp_le(far.0) & t.cmp_gt(rays.t_min) & t.cmp_lt(t_max);
        (hit.move_mask() as u32, t, [face, f32x8::ZERO])
    }
}

/// The face with outward normal ±e_`axis` as a hit's [`PrimHit::uv`] x:
/// the axis, plus 3 for the + face (as `slabs` spells them out).
#[inline]
pub(crate) fn face_code(axis: usize, positive: bool) -> f32 {
    (axis + 3 * usize::from(positive)) as f32
}

/// The axis and side of a face from [`face_code`].
#[inline]
fn face_of_code(code: f32) -> (usize, bool) {
    let code = code as usize;
    (code % 3, code >= 3)
}

impl ShapeModel for Cube {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        1
    }

    fn prim_bounds(&self, _: &[TriangleMesh], _: u32) -> Bounds3 {
        let corners: [Vec3; 8] = std::array::from_fn(|i| {
            let c = |bit: usize| if i >> bit & 1 == 0 { -1.0 } else { 1.0 };
            self.to_world.point(Vec3::new(c(0), c(1), c(2)))
        });
        Bounds3::from_points(corners)
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], _: u32, ray: &Ray) -> Option<PrimHit> {
        let [(t_near, near_face), (t_far, far_face)] = self.slabs(ray);
        let (t, face) = if t_near > ray.t_min {
            (t_near, near_face)
        } else {
            (t_far, far_face)
        };
        (t_near <= t_far && t > ray.t_min && t < ray.t_max).then_some(PrimHit {
            t,
            uv: Vec2::new(face, 0.0),
        })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        _: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let code = (hit.uv.x as usize).min(5);
        let face = &self.faces[code];
        let (on_axis, side, u_axis, v_axis) = FACE_AXES[code];
        let q = self.to_world.inv.transform_point3(ray.at(hit.t));
        let q = q.clamp(Vec3::NEG_ONE, Vec3::ONE);
        // On the face: its axis's coordinate exactly ±1 (a blend: a store to
        // a lane picked at run time would go through memory).
        let on_axis = BVec3A::from_array(on_axis);
        let q = Vec3::from(Vec3A::select(on_axis, Vec3A::splat(side), q.into()));
        // The other two coordinates (each a product by 1 and two by 0).
        let uv = (Vec2::new(q.dot(u_axis), q.dot(v_axis)) + Vec2::ONE) * 0.5;
        let p = self.to_world.point(q);
        make_interaction_in_frame(ray, hit.t, p, face.frame, uv, face.dpdu, face.dpdv)
    }

    fn surface_area(&self, _: &[TriangleMesh]) -> f32 {
        self.area
    }

    fn sample_position(&self, _: &[TriangleMesh], u: Vec2) -> PositionSample {
        // The face by area, its two sides alike, then u.x reused within it.
        let half = 0.5 * self.area;
        let mut x = u.x * half;
        let mut axis = 0;
        while axis < 2 && x >= self.face_areas[axis] {
            x -= self.face_areas[axis];
            axis += 1;
        }
        let within = (x / self.face_areas[axis]).clamp(0.0, 1.0);
        let positive = within >= 0.5;
        let su = if positive {
            2.0 * within - 1.0
        } else {
            2.0 * within
        };
        // Kept a hair off the edges, where a point rounds onto the
        // neighbouring face and a hit there would see that face's normal.
        let uv = Vec2::new(su, u.y).clamp(Vec2::splat(EDGE_INSET), Vec2::splat(1.0 - EDGE_INSET));
        let (_, side, u_axis, v_axis) = FACE_AXES[face_code(axis, positive) as usize];
        let q = Vec3::AXES[axis] * side + u_axis * (2.0 * uv.x - 1.0) + v_axis * (2.0 * uv.y - 1.0);
        PositionSample {
            p: self.to_world.point(q),
            n: self.face(axis, positive).frame.n,
            pdf: self.inv_area,
            uv,
        }
    }
}

/// The unit cube mesh in object space (call [`TriangleMesh::transform`]
/// to place it).
pub fn cube_mesh() -> TriangleMesh {
    cube_mesh_with(false)
}

/// The cube as 12 triangles with per-face vertices (flat normals, the
/// uvs of [`FACE_AXES`]), optionally with flipped normals.
pub fn cube_mesh_with(flip_normals: bool) -> TriangleMesh {
    let mut positions = Vec::with_capacity(24);
    let mut normals = Vec::with_capacity(24);
    let mut uvs = Vec::with_capacity(24);
    let mut indices = Vec::with_capacity(12);
    for (on_axis, side, u_axis, v_axis) in FACE_AXES {
        let axis = on_axis.iter().position(|a| *a).unwrap_or(0);
        let n = Vec3::AXES[axis] * side;
        let base = positions.len() as u32;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            positions.push(n + u_axis * a + v_axis * b);
            normals.push(n);
            uvs.push(Vec2::new((a + 1.0) * 0.5, (b + 1.0) * 0.5));
        }
        // Counter-clockwise seen from outside.
        if u_axis.cross(v_axis).dot(n) > 0.0 {
            indices.push([base, base + 1, base + 2]);
            indices.push([base, base + 2, base + 3]);
        } else {
            indices.push([base, base + 2, base + 1]);
            indices.push([base, base + 3, base + 2]);
        }
    }
    // Infallible: the indices above are in range by construction.
    TriangleMesh::new(positions, normals, uvs, indices, false, flip_normals).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use crate::shape::tests::{check_shape_sampling, check_uv_derivatives, closest_hit};
    use crate::shape::{MeshShape, Shape};

    #[test]
    fn cube_mesh_is_closed_and_outward() {
        let m = cube_mesh();
        assert_eq!(m.triangle_count(), 12);
        assert!((m.area() - 24.0).abs() < 1e-4);
        for tri in &m.indices {
            let p = tri.map(|i| m.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let c = (p[0] + p[1] + p[2]) / 3.0;
            assert!(n.dot(c) > 0.0, "winding must face outward");
        }
    }

    fn next_3d(rng: &mut Pcg32) -> Vec3 {
        let u = rng.next_2d();
        Vec3::new(u.x, u.y, rng.next_f32())
    }

    /// Placements: a rotated box, a sheared and mirrored one, inward.
    pub(super) fn placements() -> Vec<(Transform, bool)> {
        let rotated = glam::Affine3A::from_scale_rotation_translation(
            Vec3::new(0.5, 1.5, 0.8),
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1),
            Vec3::new(0.2, -0.4, 0.3),
        );
        let sheared = glam::Affine3A::from_cols_array(&[
            -1.2, 0.1, 0.0, 0.3, 0.9, 0.2, 0.0, -0.4, 0.7, 0.1, 0.2, -0.3,
        ]);
        vec![
            (Transform::new(rotated).unwrap(), false),
            (Transform::new(sheared).unwrap(), false),
            (Transform::new(rotated).unwrap(), true),
        ]
    }

    /// The uv at each corner of each face is that of Mitsuba 3.9.1's
    /// cube mesh (its vertex positions, normals and texcoords, printed by
    /// `mitsuba.load_dict({"type": "cube"})`).
    #[test]
    fn face_uvs_are_mitsubas() {
        #[rustfmt::skip]
        let mitsuba: [([f32; 3], [f32; 3], [f32; 2]); 24] = [
            ([1., -1., -1.], [0., -1., 0.], [0., 1.]), ([1., -1., 1.], [0., -1., 0.], [1., 1.]),
            ([-1., -1., 1.], [0., -1., 0.], [1., 0.]), ([-1., -1., -1.], [0., -1., 0.], [0., 0.]),
            ([1., 1., -1.], [0., 1., 0.], [0., 1.]), ([-1., 1., -1.], [0., 1., 0.], [1., 1.]),
            ([-1., 1., 1.], [0., 1., 0.], [1., 0.]), ([1., 1., 1.], [0., 1., 0.], [0., 0.]),
            ([1., -1., -1.], [1., 0., 0.], [0., 1.]), ([1., 1., -1.], [1., 0., 0.], [1., 1.]),
            ([1., 1., 1.], [1., 0., 0.], [1., 0.]), ([1., -1., 1.], [1., 0., 0.], [0., 0.]),
            ([1., -1., 1.], [0., 0., 1.], [0., 1.]), ([1., 1., 1.], [0., 0., 1.], [1., 1.]),
            ([-1., 1., 1.], [0., 0., 1.], [1., 0.]), ([-1., -1., 1.], [0., 0., 1.], [0., 0.]),
            ([-1., -1., 1.], [-1., 0., 0.], [0., 1.]), ([-1., 1., 1.], [-1., 0., 0.], [1., 1.]),
            ([-1., 1., -1.], [-1., 0., 0.], [1., 0.]), ([-1., -1., -1.], [-1., 0., 0.], [0., 0.]),
            ([1., 1., -1.], [0., 0., -1.], [0., 1.]), ([1., -1., -1.], [0., 0., -1.], [1., 1.]),
            ([-1., -1., -1.], [0., 0., -1.], [1., 0.]), ([-1., 1., -1.], [0., 0., -1.], [0., 0.]),
        ];
        let cube = Shape::Cube(Cube::new(Transform::IDENTITY, false));
        for (p, n, uv) in mitsuba {
            let (p, n) = (Vec3::from(p), Vec3::from(n));
            // A point just inside the corner, hit straight along −n.
            let inside = p - (p - n * n.dot(p)) * 1e-3;
            let si = closest_hit(&cube, &[], &Ray::new(inside + n, -n)).unwrap();
            assert!(
                (si.uv - Vec2::from(uv)).length() < 1e-2,
                "at {p} on {n}: {} for {uv:?}",
                si.uv
            );
        }
        // The mesh the cube becomes when it emits has the same uvs.
        let mesh = cube_mesh();
        for (p, n, uv) in mitsuba {
            let found = (0..24).any(|i| {
                mesh.positions[i] == Vec3::from(p)
                    && mesh.normals[i] == Vec3::from(n)
                    && mesh.uvs[i] == Vec2::from(uv)
            });
            assert!(found, "the mesh lacks the vertex {p:?} {n:?} {uv:?}");
        }
    }

    /// Hits on the analytic cube are the mesh cube's: the same distance,
    /// point, normals and uv (away from its edges, where either face will
    /// do), from outside and from inside.
    #[test]
    fn cube_hits_match_its_mesh() {
        let mut rng = Pcg32::new(7, 1);
        for (to_world, flip) in placements() {
            let cube = Shape::Cube(Cube::new(to_world, flip));
            let meshes = [match cube {
                Shape::Cube(c) => c.mesh(),
                _ => unreachable!(),
            }];
            let mesh = Shape::Mesh(MeshShape { mesh: 0 });
            let mut compared = [0; 2];
            for k in 0..4000 {
                let inside = k % 2 == 1;
                let origin = if inside {
                    to_world.point((next_3d(&mut rng) * 2.0 - Vec3::ONE) * 0.9)
                } else {
                    (next_3d(&mut rng) * 2.0 - Vec3::ONE) * 4.0
                };
                let target = to_world.point((next_3d(&mut rng) * 2.0 - Vec3::ONE) * 1.1);
                let ray = Ray::new(origin, (target - origin).normalize());
                let a = closest_hit(&cube, &[], &ray);
                let b = closest_hit(&mesh, &meshes, &ray);
                let (a, b) = match (a, b) {
                    (Some(a), Some(b)) => (a, b),
                    (None, None) => continue,
                    (a, b) => {
                        // Only a graze of an edge may differ.
                        let si = a.or(b).unwrap();
                        let q = to_world.inv.transform_point3(si.p).abs();
                        let mut c = q.to_array();
                        c.sort_by(f32::total_cmp);
                        assert!(c[1] > 0.999, "hit {si:?} from only one of them");
                        continue;
                    }
                };
                let q = to_world.inv.transform_point3(a.p).abs().to_array();
                if q.iter().filter(|c| **c > 0.999).count() > 1 {
                    continue;
                }
                let scale = 1e-4 * (1.0 + a.t);
                assert!((a.t - b.t).abs() < scale, "t {} vs {}", a.t, b.t);
                assert!((a.p - b.p).length() < scale, "p {} vs {}", a.p, b.p);
                assert!((a.n - b.n).length() < 1e-4, "n {} vs {}", a.n, b.n);
                let (fa, fb) = (a.sh_frame, b.sh_frame);
                for (x, y) in [(fa.s, fb.s), (fa.t, fb.t), (fa.n, fb.n)] {
                    assert!((x - y).length() < 1e-4, "frame {fa:?} vs {fb:?}");
                }
                assert!((a.uv - b.uv).length() < 1e-4, "uv {} vs {}", a.uv, b.uv);
                assert!((a.dpdu - b.dpdu).length() < 1e-3 * b.dpdu.length());
                assert!((a.dpdv - b.dpdv).length() < 1e-3 * b.dpdv.length());
                compared[inside as usize] += 1;
            }
            assert!(compared.iter().all(|&c| c > 500), "{compared:?}");
        }
    }

    #[test]
    fn cube_area_and_sampling() {
        for (to_world, flip) in placements() {
            let c = Cube::new(to_world, flip);
            assert!((c.area - c.mesh().area()).abs() < 1e-4 * c.area);
            let cube = Shape::Cube(c);
            // From inside, where each direction meets one point of it.
            check_shape_sampling(&cube, &[], to_world.point(Vec3::new(0.3, -0.2, 0.1)));
            check_uv_derivatives(&cube, Vec3::new(2.5, 1.0, -3.0), to_world.point(Vec3::ZERO));
        }
    }
}
