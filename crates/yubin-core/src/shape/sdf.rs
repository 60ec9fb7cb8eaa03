//! `sdf`: a surface given by a signed distance function, ray marched
//! (sphere tracing, Hart 1996). The function is a tree of `<sdf>`
//! elements: primitives, CSG and smooth operations, domain repetition,
//! rounding and shells, each with its own `to_world` (the node types are
//! listed under `shape/sdf_tree.rs`). Several nested `<sdf>` elements are
//! united.
//!
//! | parameter      | type      | default     | meaning |
//! |----------------|-----------|-------------|---------|
//! | `step_factor`  | float     | 1 (0.8 with a Mandelbox) | fraction of the distance stepped, in (0, 1]: below 1 for functions that overestimate the distance (rotated repeated bars, strong smooth blends, fractals) |
//! | `epsilon`      | float     | 1e-4        | a hit is where the distance falls below `epsilon` × the distance travelled along the ray |
//! | `max_steps`    | integer   | 512         | steps before a ray is taken to miss |
//! | `bbox_min`, `bbox_max` | point | computed | a box (object space) the shape is cut to; required when the tree is unbounded (infinite `repeat`, `plane`) |
//! | `uv_scale`     | float     | 1           | texture coordinates per object-space unit |
//! | `to_world`     | transform | identity    | placement of the whole tree |
//! | `flip_normals` | boolean   | false       | normals point inward |
//!
//! ```xml
//! <shape type="sdf">
//!     <float name="step_factor" value="0.75"/>
//!     <point name="bbox_min" value="-4, -4, -0.5"/>
//!     <point name="bbox_max" value="4, 4, 0.5"/>
//!     <sdf type="repeat">
//!         <vector name="cell" value="1, 1, 0"/>
//!         <sdf type="smooth_union">
//!             <float name="k" value="0.1"/>
//!             <sdf type="hex_prism"><float name="radius" value="0.1"/></sdf>
//!             <sdf type="sphere"><float name="radius" value="0.2"/></sdf>
//!         </sdf>
//!     </sdf>
//!     <bsdf type="roughconductor"/>
//! </shape>
//! ```
//!
//! **Marching.** In object space, between where the ray enters and
//! leaves the bounding box, the marcher steps `step_factor` × |d| along
//! the ray, where d is the distance at the current point; the sign of d
//! where the ray starts says which side it starts on (a refracted ray
//! marches inside). A hit is where |d| falls below `epsilon` × the
//! distance travelled (or d changes sign); after `max_steps` steps, or
//! past the box, the ray misses. The box from `bbox_min`/`bbox_max` is
//! intersected with the function (CSG), so a cut infinite repetition has
//! closed faces.
//!
//! **The hit.** The normal is the gradient from tetrahedral central
//! differences (four evaluations; Quilez, "normals for an SDF"), and the
//! point is moved onto the surface by one Newton step along it, so that
//! a ray leaving it starts on the right side. Texture coordinates are a
//! box projection: the object-space point's two coordinates across the
//! axis the normal is closest to (x → (y, z), y → (z, x), z → (x, y)),
//! times `uv_scale`; ∂p/∂u and ∂p/∂v are those of that projection on the
//! tangent plane, so bump and normal maps work. An `sdf` cannot carry an
//! area emitter (its surface has no uniform sampling).

use super::sdf_tree::{tree_from_params, Node, Op, SdfTree};
use super::{world_normal, PositionSample, PrimHit, ShapeModel, TriangleMesh};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Ray, Transform};
use crate::params::{ParamError, Params};
use glam::{Vec2, Vec3};

/// The default `step_factor` of a tree with a Mandelbox in it: at 1 and
/// 0.9 its estimate let 2 of 400 random rays step over the surface (by
/// up to 0.1 of a 12-unit box), at 0.8 none.
pub const MANDELBOX_STEP_FACTOR: f32 = 0.8;

/// A ray-marched distance function placed in the scene.
#[derive(Clone, Copy, Debug)]
pub struct SdfShape {
    /// The function, in object space.
    pub tree: &'static SdfTree,
    /// Object to world.
    pub to_world: Transform,
    /// Object-space box holding the surface.
    pub bounds: Bounds3,
    /// Fraction of the distance stepped.
    pub step_factor: f32,
    /// Hit threshold relative to the distance travelled.
    pub epsilon: f32,
    /// Steps before a miss.
    pub max_steps: u32,
    /// Texture coordinates per object-space unit.
    pub uv_scale: f32,
    /// Normals point inward.
    pub flip_normals: bool,
}

/// What one march found: the hit distance (if any) and the steps taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct March {
    /// Ray parameter of the hit.
    pub t: Option<f32>,
    /// Distance evaluations made.
    pub steps: u32,
}

impl SdfShape {
    /// The `sdf` shape from its parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let tree = tree_from_params(p)?
            .ok_or_else(|| p.error("an sdf shape needs at least one nested <sdf> element"))?;
        Self::with_tree(p, tree)
    }

    /// The `mandelbox` shape: a tree of one Mandelbox node.
    pub fn mandelbox_from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let m = super::mandelbox::Mandelbox::from_params(p)?;
        Self::with_tree(p, SdfTree::single(Node::Mandelbox(m)))
    }

    /// The marching parameters of `p` around `tree`.
    fn with_tree(p: &mut dyn Params, tree: SdfTree) -> Result<Self, ParamError> {
        let fractal = tree.nodes().iter().any(|n| matches!(n, Node::Mandelbox(_)));
        let default_step = if fractal { MANDELBOX_STEP_FACTOR } else { 1.0 };
        let step_factor = p.float_or("step_factor", default_step)?;
        if !(step_factor > 0.0 && step_factor <= 1.0) {
            return Err(p.param_error("step_factor", "must be in (0, 1]"));
        }
        let epsilon = p.float_or("epsilon", 1e-4)?;
        if !(epsilon > 0.0 && epsilon < 0.1) {
            return Err(p.param_error("epsilon", "must be in (0, 0.1)"));
        }
        let max_steps = p.positive_integer_or("max_steps", 512)?;
        let uv_scale = p.positive_float_or("uv_scale", 1.0)?;
        let flip_normals = p.boolean_or("flip_normals", false)?;
        let to_world = p.transform_or_identity("to_world")?;
        let (tree, bounds) = match (p.point("bbox_min")?, p.point("bbox_max")?) {
            (None, None) => {
                let b = tree.bounds();
                if !(b.min.is_finite() && b.max.is_finite()) {
                    return Err(p.error(
                        "this sdf is unbounded (an infinite repeat or a plane): \
                         give its box with bbox_min and bbox_max",
                    ));
                }
                (tree, b)
            }
            (Some(min), Some(max)) => {
                let user = Bounds3 { min, max };
                if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
                    return Err(p.param_error("bbox_min", "must be finite and below bbox_max"));
                }
                (cut_to_box(tree, user), user)
            }
            _ => return Err(p.error("give both bbox_min and bbox_max, or neither")),
        };
        if bounds.is_empty() {
            return Err(p.error("this sdf is empty (its parts' boxes do not overlap)"));
        }
        Ok(Self {
            tree: tree.interned(),
            to_world,
            bounds,
            step_factor,
            epsilon,
            max_steps,
            uv_scale,
            flip_normals,
        })
    }

    /// Marches `ray` (world space) through the shape's box: the first hit
    /// in (t_min, t_max) and the steps it took.
    pub fn march(&self, ray: &Ray) -> March {
        let o = self.to_world.inv.transform_point3(ray.o);
        let d = self.to_world.inv.transform_vector3(ray.d);
        let Some((t0, t1)) = slab(&self.bounds, o, d, ray.t_min, ray.t_max) else {
            return March { t: None, steps: 0 };
        };
        let speed = d.length();
        let floor = 1e-6 * (1.0 + o.abs().max_element());
        let mut t = t0;
        let mut sign = 0.0;
        for step in 0..self.max_steps {
            let f = self.tree.distance(o + d * t);
            if sign == 0.0 {
                sign = if f < 0.0 { -1.0 } else { 1.0 };
            }
            let f = f * sign;
            let threshold = (self.epsilon * t * speed).max(floor);
            if f < threshold {
                if t > ray.t_min {
                    return March {
                        t: (t < ray.t_max).then_some(t),
                        steps: step + 1,
                    };
                }
                // A ray that starts on the surface: stepped past it, its
                // side found again.
                t += 2.0 * threshold / speed;
                sign = 0.0;
                continue;
            }
            t += self.step_factor * f / speed;
            if t > t1 {
                return March {
                    t: None,
                    steps: step + 1,
                };
            }
        }
        March {
            t: None,
            steps: self.max_steps,
        }
    }

    /// The unit gradient at `p` (object space), by tetrahedral central
    /// differences with step `h`.
    fn gradient(&self, p: Vec3, h: f32) -> Vec3 {
        const K: [Vec3; 4] = [
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        let g = K
            .iter()
            .fold(Vec3::ZERO, |g, k| g + *k * self.tree.distance(p + *k * h));
        let len = g.length();
        if len > 0.0 && len.is_finite() {
            g / len
        } else {
            Vec3::Z
        }
    }

    /// The difference step at a hit `travelled` object-space units from
    /// the ray's origin: the hit threshold, at least 10⁻⁵ of the box.
    fn difference_step(&self, travelled: f32) -> f32 {
        let diag = self.bounds.extent().length();
        (self.epsilon * travelled).max(1e-5 * diag)
    }
}

/// The object-space hit, with the normal's dominant axis for the uv
/// projection.
fn box_projection(p: Vec3, n: Vec3, scale: f32) -> (Vec2, Vec3, Vec3) {
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
    let unit = |i: usize| Vec3::AXES[i];
    let uv = Vec2::new(p[b], p[c]) * scale;
    let dpdu = (unit(b) - unit(axis) * (n[b] / n[axis])) / scale;
    let dpdv = (unit(c) - unit(axis) * (n[c] / n[axis])) / scale;
    (uv, dpdu, dpdv)
}

/// The part of (t_min, t_max) where the ray `o + t d` is inside `b`.
#[inline]
pub(crate) fn slab(b: &Bounds3, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
    let inv = d.recip();
    let ta = (b.min - o) * inv;
    let tb = (b.max - o) * inv;
    // NaN (a ray in a face's plane) counts as inside that slab.
    let near = ta.min(tb);
    let far = ta.max(tb);
    let t0 = [near.x, near.y, near.z]
        .into_iter()
        .filter(|v| !v.is_nan())
        .fold(t_min, f32::max);
    let t1 = [far.x, far.y, far.z]
        .into_iter()
        .filter(|v| !v.is_nan())
        .fold(t_max, f32::min);
    (t0 <= t1).then_some((t0, t1))
}

/// `tree` intersected with the box `b`.
fn cut_to_box(tree: SdfTree, b: Bounds3) -> SdfTree {
    let mut nodes = tree.nodes().to_vec();
    let root = nodes.len() as u32 - 1;
    nodes.push(Node::Box {
        center: b.center(),
        half: b.extent() * 0.5,
    });
    let cut = nodes.len() as u32 - 1;
    nodes.push(Node::Combine {
        op: Op::Intersection,
        a: root,
        b: cut,
    });
    SdfTree::from_nodes(nodes)
}

impl ShapeModel for SdfShape {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        1
    }

    fn prim_bounds(&self, _: &[TriangleMesh], _: u32) -> Bounds3 {
        Bounds3::from_points(self.bounds.corners().map(|c| self.to_world.point(c)))
    }

    fn intersect(&self, _: &[TriangleMesh], _: u32, ray: &Ray) -> Option<PrimHit> {
        self.march(ray).t.map(|t| PrimHit { t, uv: Vec2::ZERO })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        _: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let o = self.to_world.inv.transform_point3(ray.o);
        let d = self.to_world.inv.transform_vector3(ray.d);
        let mut p = o + d * hit.t;
        let h = self.difference_step(hit.t * d.length());
        let mut n = self.gradient(p, h);
        // One Newton step onto the surface, then the normal there.
        p -= n * self.tree.distance(p);
        n = self.gradient(p, h);
        let (uv, dpdu, dpdv) = box_projection(p, n, self.uv_scale);
        let normal = world_normal(&self.to_world, n, self.flip_normals);
        super::make_interaction(
            ray,
            hit.t,
            self.to_world.point(p),
            normal,
            uv,
            self.to_world.vector(dpdu),
            self.to_world.vector(dpdv),
        )
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

    fn shape(tree: SdfTree) -> SdfShape {
        let bounds = tree.bounds();
        SdfShape {
            tree: tree.interned(),
            to_world: Transform::IDENTITY,
            bounds,
            step_factor: 1.0,
            epsilon: 1e-4,
            max_steps: 512,
            uv_scale: 1.0,
            flip_normals: false,
        }
    }

    #[test]
    fn box_projection_derivatives_lie_in_the_tangent_plane() {
        let n = Vec3::new(0.3, -0.8, 0.5).normalize();
        let (_, dpdu, dpdv) = box_projection(Vec3::ONE, n, 2.0);
        assert!(dpdu.dot(n).abs() < 1e-6 && dpdv.dot(n).abs() < 1e-6);
        // y dominant: u follows z, v follows x.
        assert!((dpdu.z - 0.5).abs() < 1e-6 && (dpdv.x - 0.5).abs() < 1e-6);
    }

    #[test]
    fn a_ray_starting_on_the_surface_passes_it() {
        let s = shape(SdfTree::single(Node::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        }));
        let on = Vec3::new(1.0, 0.0, 0.0);
        let mut out = Ray::new(on, Vec3::X);
        out.t_min = 1e-7;
        assert_eq!(s.march(&out).t, None);
        let mut through = Ray::new(on, -Vec3::X);
        through.t_min = 1e-7;
        let t = s.march(&through).t.unwrap();
        assert!((t - 2.0).abs() < 1e-3, "{t}");
    }

    #[test]
    fn a_ray_from_inside_finds_the_way_out() {
        let s = shape(SdfTree::single(Node::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        }));
        let t = s
            .march(&Ray::new(Vec3::new(0.2, 0.0, 0.0), Vec3::X))
            .t
            .unwrap();
        assert!((t - 0.8).abs() < 1e-4);
    }

    #[test]
    fn max_steps_turns_into_a_miss() {
        // A ray that passes just outside a sphere, or just clips it, takes
        // ever shorter steps near it; with few steps allowed the clipping
        // ray gives up and misses instead of marching on.
        let mut s = shape(SdfTree::single(Node::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        }));
        let ray_at = |r: f32| {
            let c = r / 2f32.sqrt();
            Ray::new(Vec3::new(-3.0, c, c), Vec3::X)
        };
        let outside = s.march(&ray_at(1.0 + 1e-3));
        assert_eq!(outside.t, None);
        assert!(outside.steps > 8, "{outside:?}");
        let clipping = s.march(&ray_at(1.0 - 1e-3));
        assert!(clipping.t.is_some() && clipping.steps > 8, "{clipping:?}");
        s.max_steps = 8;
        assert_eq!(s.march(&ray_at(1.0 - 1e-3)), March { t: None, steps: 8 });
    }

    /// The interval (t0, t1) where a unit ray is inside a sphere.
    fn sphere_interval(ray: &Ray, c: Vec3, r: f32) -> Option<(f32, f32)> {
        let oc = ray.o - c;
        let b = oc.dot(ray.d);
        let disc = b * b - (oc.length_squared() - r * r);
        (disc > 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
    }

    /// CSG of two spheres hits where the closed-form intervals say, on
    /// random rays from outside: within the hit threshold, never missed.
    #[test]
    fn csg_of_spheres_matches_closed_form_intervals() {
        let (ca, ra) = (Vec3::new(-0.3, 0.0, 0.0), 1.0);
        let (cb, rb) = (Vec3::new(0.4, 0.2, 0.1), 0.8);
        let a = Node::Sphere {
            center: ca,
            radius: ra,
        };
        let b = Node::Sphere {
            center: cb,
            radius: rb,
        };
        let mut rng = crate::sampler::Pcg32::new(11, 0);
        for op in [Op::Intersection, Op::Difference] {
            let s = shape(SdfTree::from_nodes(vec![
                a.clone(),
                b.clone(),
                Node::Combine { op, a: 0, b: 1 },
            ]));
            let (mut hits, mut checked) = (0, 0);
            for _ in 0..4000 {
                let o = crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 4.0;
                let target = (rng.next_2d() * 2.4 - glam::Vec2::splat(1.2))
                    .extend(rng.next_f32() * 2.0 - 1.0);
                let ray = Ray::new(o, (target - o).normalize());
                let (ia, ib) = (sphere_interval(&ray, ca, ra), sphere_interval(&ray, cb, rb));
                let expected = ia.and_then(|ia| match (op, ib) {
                    (Op::Intersection, Some(ib)) => {
                        let (t0, t1) = (ia.0.max(ib.0), ia.1.min(ib.1));
                        (t0 < t1).then_some((t0, t1 - t0))
                    }
                    (Op::Intersection, None) => None,
                    (_, Some(ib)) if ib.0 <= ia.0 && ia.0 <= ib.1 => {
                        (ib.1 < ia.1).then_some((ib.1, ia.1 - ib.1))
                    }
                    _ => Some((ia.0, ia.1 - ia.0)),
                });
                let marched = s.march(&ray).t;
                match expected {
                    // Chords shorter than the threshold may be missed:
                    // such rays only graze the solid.
                    Some((t, chord)) if chord > 1e-2 => {
                        let m = marched
                            .unwrap_or_else(|| panic!("{op:?}: missed {ray:?}, expected {t}"));
                        // Never past the surface; before it by at most the
                        // threshold over the cosine of incidence (×2 for
                        // the bound's looseness at the crease).
                        let p = ray.at(t);
                        let n = if (p - ca).length() > ra - 1e-4 && (p - ca).length() < ra + 1e-4 {
                            (p - ca).normalize()
                        } else {
                            (p - cb).normalize()
                        };
                        let cos = n.dot(ray.d).abs();
                        if cos < 0.1 {
                            continue;
                        }
                        let slack = 2.0 * s.epsilon * t / cos;
                        assert!(
                            m <= t + 1e-5 * t && m >= t - slack,
                            "{op:?}: {m} for {t} (cos {cos})"
                        );
                        hits += 1;
                    }
                    Some(_) => {}
                    // A ray that passes within the threshold may hit.
                    None => {
                        if let Some(m) = marched {
                            let p = ray.at(m);
                            let (da, db) = ((p - ca).length() - ra, (p - cb).length() - rb);
                            let near = match op {
                                Op::Intersection => da.max(db) < 1e-3,
                                _ => da < 1e-3 && db > -1e-3,
                            };
                            assert!(near, "{op:?}: hit at {m} on {ray:?} ({da}, {db})");
                        }
                    }
                }
                checked += 1;
            }
            assert!(
                hits > 500 && checked > 2000,
                "{op:?}: {hits} hits of {checked}"
            );
        }
    }

    /// The Mandelbox's estimate never lets the marcher step over the
    /// surface: on random rays, the marched hit is where fine stepping
    /// (1/4000 of the box) finds the estimate first below the hit
    /// threshold, within a fine step.
    #[test]
    fn mandelbox_marching_never_overshoots() {
        let m = super::super::mandelbox::Mandelbox::new(2.0, 12);
        let mut s = shape(SdfTree::single(Node::Mandelbox(m)));
        s.max_steps = 4000;
        s.step_factor = MANDELBOX_STEP_FACTOR;
        let h = 2.0 * m.half_extent() / 4000.0;
        let mut rng = crate::sampler::Pcg32::new(5, 0);
        let mut hits = 0;
        for _ in 0..400 {
            let o = crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 12.0;
            let target =
                crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 3.0 * rng.next_f32();
            let ray = Ray::new(o, (target - o).normalize());
            let marched = s.march(&ray);
            let (t0, t1) = slab(&s.bounds, ray.o, ray.d, 0.0, f32::INFINITY).unwrap();
            let mut t = t0;
            let fine = loop {
                if t > t1 {
                    break None;
                }
                if m.distance(ray.at(t)) < s.epsilon * t {
                    break Some(t);
                }
                t += h;
            };
            // Stepping over a surface that fine stepping finds would show
            // as a later hit or a miss; a hit must be where the estimate
            // is below the threshold (fine stepping may step over a sliver
            // the marcher landed in: that is not an overshoot).
            match (marched.t, fine) {
                (Some(tm), tf) => {
                    assert!(
                        m.distance(ray.at(tm)) < s.epsilon * tm,
                        "no surface at {tm}"
                    );
                    if let Some(tf) = tf {
                        assert!(tm <= tf + h, "overshoot: marched {tm}, surface at {tf}");
                    }
                    hits += 1;
                }
                (None, None) => {}
                (None, Some(tf)) => {
                    panic!("marched past the surface at {tf} ({} steps)", marched.steps)
                }
            }
        }
        assert!(hits > 100, "{hits} hits");
    }
}
