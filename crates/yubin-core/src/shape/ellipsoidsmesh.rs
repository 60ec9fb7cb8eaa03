//! `ellipsoidsmesh`: the Gaussians of `ellipsoids`, each drawn as a
//! triangle shell that encloses its ellipsoid (Mitsuba 3's
//! `ellipsoidsmesh`): faceted, with flat normals.
//!
//! | parameter  | type   | default      | meaning |
//! |------------|--------|--------------|---------|
//! | `shell`    | string | `ico_sphere` | `ico_sphere` (or `default`: 20 triangles), `uv_sphere` (72) or `box` (12) |
//! | (others)   |        |              | as `ellipsoids`: `filename`, `extent`, `extent_adaptive_clamping`, `scale_factor`, `to_world` |
//!
//! ```xml
//! <shape type="ellipsoidsmesh">
//!     <string name="filename" value="splats.ply"/>
//!     <string name="shell" value="ico_sphere"/>
//! </shape>
//! ```
//!
//! Each shell is Mitsuba's template mapped onto the ellipsoid (vertex v →
//! c + R diag(a) v). The templates are scaled, as Mitsuba scales them, so
//! that the face nearest the centre has its centroid at distance 1: the
//! icosahedron then touches the unit sphere from outside (it encloses the
//! ellipsoid), the 72-triangle uv sphere dips 1.4 % inside it and the box
//! (half-size 0.9045) 10 %. Every template is convex, so a ray is tested
//! against the shell as a convex polyhedron (where it enters every face's
//! plane before it leaves any), which is the triangle test with back
//! faces culled that Mitsuba makes: rays see only where they enter, and
//! one starting inside sees nothing. A hit has the face's flat normal and
//! its barycentric coordinates as uv, as a Mitsuba mesh without texture
//! coordinates has (the uv sphere's triangles are split here in an order
//! of their own, so its uv may differ from Mitsuba's). A nested mesh as the
//! shell is not supported.
//!
//! Reference: Mitsuba 3 documentation, "Ellipsoids (ellipsoidsmesh)".

use super::ellipsoids::EllipsoidsData;
use super::{make_interaction, PositionSample, PrimHit, ShapeModel, TriangleMesh};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Ray};
use crate::params::{Family, ParamError, Params};
use glam::{Vec2, Vec3};

/// A convex shell about the unit sphere.
#[derive(Clone, Debug, PartialEq)]
pub struct Shell {
    /// Vertices.
    pub vertices: Vec<Vec3>,
    /// Triangles, wound outward.
    pub faces: Vec<[u32; 3]>,
    /// Each face's plane: outward unit normal and distance from the
    /// centre.
    planes: Vec<(Vec3, f32)>,
}

impl Shell {
    /// The shell of `vertices` and `faces`, scaled as Mitsuba scales its
    /// templates (the nearest vertex or face centroid at distance 1).
    fn new(vertices: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Shell {
        let nearest = faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| vertices[i as usize]);
                [a, b, c, (a + b + c) / 3.0]
                    .iter()
                    .map(|v| v.length())
                    .fold(f32::INFINITY, f32::min)
            })
            .fold(f32::INFINITY, f32::min);
        let vertices: Vec<Vec3> = vertices.iter().map(|v| *v / nearest).collect();
        let planes = faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| vertices[i as usize]);
                let n = (b - a).cross(c - a).normalize();
                (n, n.dot(a))
            })
            .collect();
        Shell {
            vertices,
            faces,
            planes,
        }
    }

    /// The shell stored for the program's life, once per content.
    fn interned(self) -> &'static Shell {
        static INTERNED: std::sync::Mutex<Vec<&'static Shell>> = std::sync::Mutex::new(Vec::new());
        super::interned(&INTERNED, self)
    }

    /// The regular icosahedron, poles on ±y (Mitsuba's `ico_sphere`).
    fn icosahedron() -> Shell {
        let ring = |y: f32, first_degrees: f32| {
            (0..5).map(move |k| {
                let phi = (first_degrees + 72.0 * k as f32).to_radians();
                let r = 2.0 / 5f32.sqrt();
                Vec3::new(r * phi.cos(), y, r * phi.sin())
            })
        };
        let below = -1.0 / 5f32.sqrt();
        let mut v = vec![Vec3::NEG_Y];
        v.extend(ring(below, 36.0));
        // Mitsuba's upper ring runs from 72° round to 0°.
        v.extend(ring(-below, 72.0));
        v.push(Vec3::Y);
        const FACES: [[u32; 3]; 20] = [
            [0, 1, 2],
            [1, 0, 5],
            [0, 2, 3],
            [0, 3, 4],
            [0, 4, 5],
            [1, 5, 10],
            [2, 1, 6],
            [3, 2, 7],
            [4, 3, 8],
            [5, 4, 9],
            [1, 10, 6],
            [2, 6, 7],
            [3, 7, 8],
            [4, 8, 9],
            [5, 9, 10],
            [6, 10, 11],
            [7, 6, 11],
            [8, 7, 11],
            [9, 8, 11],
            [10, 9, 11],
        ];
        Shell::new(v, FACES.to_vec())
    }

    /// A uv sphere of 9 meridians 40° apart (from −50°) and 4 parallels
    /// 36° apart (Mitsuba's `uv_sphere`: 38 vertices, 72 triangles).
    fn uv_sphere() -> Shell {
        let (meridians, parallels) = (9u32, 4u32);
        let mut v = Vec::new();
        for m in 0..meridians {
            let phi = (-50.0 + 40.0 * m as f32).to_radians();
            for k in 1..=parallels {
                let theta = (36.0 * k as f32).to_radians();
                v.push(Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                ));
            }
        }
        let (top, bottom) = (v.len() as u32, v.len() as u32 + 1);
        v.extend([Vec3::Y, Vec3::NEG_Y]);
        let at = |m: u32, k: u32| (m % meridians) * parallels + k;
        let mut faces = Vec::new();
        for m in 0..meridians {
            faces.push([top, at(m + 1, 0), at(m, 0)]);
            for k in 0..parallels - 1 {
                let (a, b) = (at(m, k), at(m + 1, k));
                let (c, d) = (at(m, k + 1), at(m + 1, k + 1));
                faces.extend([[a, b, d], [a, d, c]]);
            }
            faces.push([bottom, at(m, parallels - 1), at(m + 1, parallels - 1)]);
        }
        let mut shell = Shell::new(v, faces);
        shell.orient_outward();
        shell
    }

    /// The cube [−1, 1]³ (Mitsuba's `box`).
    fn cube() -> Shell {
        let v: Vec<Vec3> = (0..8)
            .map(|i| {
                let s = |bit: u32| if i & bit != 0 { 1.0 } else { -1.0 };
                Vec3::new(s(1), s(2), s(4))
            })
            .collect();
        let quads = [
            [0, 2, 6, 4],
            [1, 5, 7, 3],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 1, 3, 2],
            [4, 6, 7, 5],
        ];
        let faces = quads
            .iter()
            .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
            .collect();
        let mut shell = Shell::new(v, faces);
        shell.orient_outward();
        shell
    }

    /// Winds every face so that its normal points away from the centre.
    fn orient_outward(&mut self) {
        for (f, plane) in self.faces.iter_mut().zip(&mut self.planes) {
            if plane.1 < 0.0 {
                f.swap(1, 2);
                *plane = (-plane.0, -plane.1);
            }
        }
    }

    /// Where the ray `o + t d` (the shell's space) enters the shell, and
    /// through which face: the last plane it enters, if it leaves none
    /// before.
    #[inline]
    fn enter(&self, o: Vec3, d: Vec3) -> Option<(f32, usize)> {
        let (mut t_in, mut t_out, mut face) = (f32::NEG_INFINITY, f32::INFINITY, 0);
        for (i, &(n, dist)) in self.planes.iter().enumerate() {
            let along = n.dot(d);
            let gap = dist - n.dot(o);
            if along < 0.0 {
                let t = gap / along;
                if t > t_in {
                    t_in = t;
                    face = i;
                }
            } else if along > 0.0 {
                t_out = t_out.min(gap / along);
            } else if gap < 0.0 {
                return None;
            }
        }
        (t_in <= t_out).then_some((t_in, face))
    }

    /// The face holding point `p` on the plane of `face` (a coplanar
    /// neighbour when `p` is past its edge) and `p`'s barycentric
    /// coordinates (b1, b2) in it.
    fn barycentric(&self, face: usize, p: Vec3) -> (usize, Vec2) {
        let normal = self.planes[face].0;
        let mut best = (face, Vec2::ZERO, f32::NEG_INFINITY);
        for (i, f) in self.faces.iter().enumerate() {
            if self.planes[i].0.dot(normal) < 0.9999 {
                continue;
            }
            let [a, b, c] = f.map(|k| self.vertices[k as usize]);
            let (e1, e2, w) = (b - a, c - a, p - a);
            let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let (w1, w2) = (w.dot(e1), w.dot(e2));
            let det = d11 * d22 - d12 * d12;
            let b1 = (d22 * w1 - d12 * w2) / det;
            let b2 = (d11 * w2 - d12 * w1) / det;
            let inside = b1.min(b2).min(1.0 - b1 - b2);
            if inside > best.2 {
                best = (i, Vec2::new(b1, b2), inside);
            }
        }
        (best.0, best.1)
    }
}

/// An `ellipsoidsmesh` shape.
#[derive(Clone, Copy, Debug)]
pub struct EllipsoidsMesh {
    /// The Gaussians.
    pub data: &'static EllipsoidsData,
    /// The shell drawn for each.
    pub shell: &'static Shell,
}

impl EllipsoidsMesh {
    /// The shape from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        if p.child(Family::Shape)?.is_some() {
            return Err(
                p.error("a shell from a nested mesh is not supported: give `shell` as a string")
            );
        }
        let shell = match p.string("shell")?.as_deref() {
            None | Some("default" | "ico_sphere") => Shell::icosahedron(),
            Some("uv_sphere") => Shell::uv_sphere(),
            Some("box") => Shell::cube(),
            Some(other) => {
                return Err(p.param_error(
                    "shell",
                    &format!("shell '{other}' is not one of default, ico_sphere, uv_sphere, box"),
                ))
            }
        };
        Ok(Self {
            data: EllipsoidsData::from_params(p)?,
            shell: shell.interned(),
        })
    }
}

impl ShapeModel for EllipsoidsMesh {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        self.data.ellipsoids.len() as u32
    }

    fn prim_bounds(&self, _: &[TriangleMesh], prim: u32) -> Bounds3 {
        let e = &self.data.ellipsoids[prim as usize];
        let m = e.from_unit();
        let mut b = Bounds3::EMPTY;
        for v in &self.shell.vertices {
            b = b.union_point(e.center + m * *v);
        }
        b
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], prim: u32, ray: &Ray) -> Option<PrimHit> {
        let e = &self.data.ellipsoids[prim as usize];
        let (o, d) = e.ray_to_unit(ray);
        let (t, face) = self.shell.enter(o, d)?;
        (t > ray.t_min && t <= ray.t_max).then_some(PrimHit {
            t,
            uv: Vec2::new(face as f32, 0.0),
        })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let e = &self.data.ellipsoids[prim as usize];
        let (o, d) = e.ray_to_unit(ray);
        let (face, uv) = self.shell.barycentric(hit.uv.x as usize, o + d * hit.t);
        let m = e.from_unit();
        let [a, b, c] = self.shell.faces[face].map(|k| m * self.shell.vertices[k as usize]);
        let n = (e.to_unit.transpose() * self.shell.planes[face].0).normalize();
        make_interaction(ray, hit.t, ray.at(hit.t), n, uv, b - a, c - a)
    }

    fn surface_area(&self, _: &[TriangleMesh]) -> f32 {
        0.0
    }

    fn sample_position(&self, _: &[TriangleMesh], _: Vec2) -> PositionSample {
        PositionSample::NONE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The templates' sizes as Mitsuba 3.9.1 scales them: vertex radius
    /// and nearest face plane.
    #[test]
    fn shells_are_scaled_as_mitsubas() {
        let radius = |s: &Shell| s.vertices.iter().map(|v| v.length()).fold(0.0, f32::max);
        let nearest = |s: &Shell| s.planes.iter().map(|p| p.1).fold(f32::INFINITY, f32::min);
        let ico = Shell::icosahedron();
        assert!((radius(&ico) - 1.258425).abs() < 2e-5, "{}", radius(&ico));
        assert!((nearest(&ico) - 1.0).abs() < 1e-5);
        assert!((ico.vertices[1] - Vec3::new(0.910597, -0.562787, 0.661579)).length() < 2e-5);
        assert!((ico.vertices[10] - Vec3::new(1.125567, 0.562787, 0.0)).length() < 2e-5);
        let uv = Shell::uv_sphere();
        assert_eq!((uv.vertices.len(), uv.faces.len()), (38, 72));
        assert!((radius(&uv) - 1.103597).abs() < 2e-5, "{}", radius(&uv));
        assert!((nearest(&uv) - 0.986286).abs() < 2e-5, "{}", nearest(&uv));
        let cube = Shell::cube();
        assert_eq!(cube.faces.len(), 12);
        assert!(
            (nearest(&cube) - 0.904534).abs() < 2e-5,
            "{}",
            nearest(&cube)
        );
        for s in [&ico, &uv, &cube] {
            assert!(s.planes.iter().all(|p| p.1 > 0.0));
        }
    }

    /// The convex test agrees with culled triangle tests: a ray from
    /// outside enters through the face it crosses, from inside it sees
    /// nothing.
    #[test]
    fn rays_enter_through_the_face_they_cross() {
        let ico = Shell::icosahedron();
        let (t, face) = ico.enter(Vec3::new(0.05, 0.1, 5.0), Vec3::NEG_Z).unwrap();
        let p = Vec3::new(0.05, 0.1, 5.0 - t);
        let (f, b) = ico.barycentric(face, p);
        assert_eq!(f, face);
        assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0, "{b}");
        assert!((ico.planes[face].0.dot(p) - ico.planes[face].1).abs() < 1e-5);
        assert!(ico.enter(Vec3::ZERO, Vec3::X).is_some_and(|(t, _)| t < 0.0));
        assert!(ico.enter(Vec3::new(0.0, 5.0, 0.0), Vec3::X).is_none());
    }
}
