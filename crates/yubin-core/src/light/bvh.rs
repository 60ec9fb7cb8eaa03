//! The light BVH: chooses a light for a shading point with probability
//! roughly proportional to its contribution there, in O(log n).
//!
//! Conty Estevez and Kulla 2018, "Importance Sampling of Many Lights with
//! Adaptive Tree Splitting" (HPG), as pbrt-v4 §12.6.3 presents it. Each
//! node bounds its lights by a box, their total power φ, a cone of
//! emission normals (axis w, half-angle θo) and the spread θe of emission
//! about a normal (π/2 for a diffuse surface). At a point p with normal n
//! a node's importance is
//!
//! φ · cos θ′ · cos θi′ / d²,
//!
//! where d is the distance to the box's centre, d² clamped from below by
//! half the box diagonal's *length* (pbrt-v4's clamp: not scale-invariant,
//! but clamping d by half the diagonal instead flattens the importance of
//! every large node around the point to its power, so the tree stops
//! telling near lights from far ones where it matters most), θ′ = max(0, θw − θo − θb) the angle between w and the
//! direction to p beyond what the normal cone and the box's angular size
//! θb can absorb (0 importance when θ′ ≥ θe), and θi′ = max(0, θi − θb)
//! the same at the receiver. Traversal picks a child with probability
//! proportional to its importance, multiplying the probabilities; each
//! light's path from the root (its bit trail) gives its probability again
//! for MIS. The tree is built top-down with the surface area orientation
//! heuristic (the paper's SAOH, binned along each axis).
//!
//! Importance is only an estimate: it sees a light's power as one number
//! (its largest RGB channel, as pbrt-v4 takes the spectrum's maximum) and
//! a point lit head-on by one light and at grazing by another of another
//! colour would choose the second too rarely for that colour's channel.
//! The tree's choice is therefore mixed with a uniform choice among its
//! lights (defensive importance sampling, Hesterberg 1995): probability
//! (1 − α) · p_tree + α / n, α = [`DEFENSIVE_FRACTION`], so no light is
//! ever more than n/α times rarer than under uniform choice, at the cost
//! of at most 1/(1 − α) more variance where the tree's guess is right.
//!
//! Emissive meshes enter triangle by triangle, so that the triangles near
//! a point are preferred over the far ones. Lights at infinity
//! (`constant`, `envmap`, `directional`) have no useful bounds: they are
//! chosen outside the tree, each with probability
//! 1 / (their number + 1) (pbrt's rule), the tree getting the rest.
//! `directionalarea` lights, which no point can sample, are never chosen.
//! Lights with zero power are never chosen (BSDF sampling still finds
//! them, with full MIS weight).

use super::selection::LightChoice;
use super::{Emitter, EmitterContext};
use crate::math::Bounds3;
use crate::shape::{Shape, ShapeModel};
use glam::Vec3;
use std::f32::consts::{FRAC_PI_2, PI};

/// What a node knows of the lights below it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// Box around the emitting points.
    pub bounds: Bounds3,
    /// Total emitted power (largest channel).
    pub phi: f32,
    /// Axis of the cone of emission normals.
    pub w: Vec3,
    /// Cosine of the normal cone's half-angle θo.
    pub cos_theta_o: f32,
    /// Cosine of the emission spread θe about a normal.
    pub cos_theta_e: f32,
    /// Emits on both sides of its normals.
    pub two_sided: bool,
}

/// cos(max(0, a − b)) from sines and cosines.
#[inline]
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// sin(max(0, a − b)) from sines and cosines.
#[inline]
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

#[inline]
fn sin_from_cos(c: f32) -> f32 {
    (1.0 - c * c).max(0.0).sqrt()
}

/// The smallest cone around two cones (axes unit, half-angles θ); `None`
/// for the whole sphere.
fn cone_union(wa: Vec3, theta_a: f32, wb: Vec3, theta_b: f32) -> (Vec3, f32) {
    if theta_a >= PI || theta_b >= PI {
        return (wa, PI);
    }
    let theta_d = wa.dot(wb).clamp(-1.0, 1.0).acos();
    if theta_d + theta_b <= theta_a {
        return (wa, theta_a);
    }
    if theta_d + theta_a <= theta_b {
        return (wb, theta_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    if theta_o >= PI {
        return (wa, PI);
    }
    let axis = wa.cross(wb);
    if axis.length_squared() < 1e-12 {
        return (wa, PI);
    }
    let w = glam::Quat::from_axis_angle(axis.normalize(), theta_o - theta_a) * wa;
    (w.normalize(), theta_o)
}

impl LightBounds {
    /// The bounds of both.
    pub fn union(&self, o: &LightBounds) -> LightBounds {
        if self.phi == 0.0 {
            return *o;
        }
        if o.phi == 0.0 {
            return *self;
        }
        let (w, theta_o) = cone_union(
            self.w,
            self.cos_theta_o.clamp(-1.0, 1.0).acos(),
            o.w,
            o.cos_theta_o.clamp(-1.0, 1.0).acos(),
        );
        LightBounds {
            bounds: self.bounds.union(o.bounds),
            phi: self.phi + o.phi,
            w,
            cos_theta_o: theta_o.cos(),
            cos_theta_e: self.cos_theta_e.min(o.cos_theta_e),
            two_sided: self.two_sided || o.two_sided,
        }
    }

    /// The importance at point `p` with normal `n` (zero: no normal).
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let pc = self.bounds.center();
        let half_diag2 = 0.25 * self.bounds.extent().length_squared();
        let dist2 = p.distance_squared(pc);
        let d2 = dist2.max(half_diag2.sqrt()).max(1e-12); // see the module docs
        let wi = (p - pc).normalize_or_zero();
        let mut cos_w = self.w.dot(wi);
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = sin_from_cos(cos_w);
        // The angle the box subtends seen from p (all directions inside).
        let cos_b = if dist2 < half_diag2 {
            -1.0
        } else {
            (1.0 - half_diag2 / dist2).max(0.0).sqrt()
        };
        let sin_b = sin_from_cos(cos_b);
        let sin_o = sin_from_cos(self.cos_theta_o);
        let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        let mut importance = self.phi * cos_p / d2;
        if n != Vec3::ZERO {
            let cos_i = wi.dot(n).abs();
            let sin_i = sin_from_cos(cos_i);
            importance *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
        }
        importance.max(0.0)
    }
}

/// A node: its bounds, and its light (leaf) or its children (the first
/// right after it, the second at `index`).
#[derive(Clone, Copy, Debug)]
struct Node {
    lb: LightBounds,
    /// Leaf: index into `lights`. Interior: index of the second child (the
    /// first is the next node).
    index: u32,
    leaf: bool,
}

/// The path from the root to a light's leaf: bit k says which child
/// (1: the second) at depth k.
type Trail = u64;

/// A light that has no leaf (lost at [`MAX_DEPTH`], or without power).
const NO_TRAIL: Trail = u64::MAX;

/// The tree and the lights outside it (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct LightBvh {
    nodes: Vec<Node>,
    /// The lights of the leaves.
    lights: Vec<LightChoice>,
    /// Per emitter: the first entry of `trails` for it (its triangles
    /// follow one by one when split), or `u32::MAX` when not in the tree.
    first_trail: Vec<u32>,
    /// Per emitter: whether its mesh's triangles are separate lights.
    split: Vec<bool>,
    trails: Vec<Trail>,
    /// Emitters chosen outside the tree, uniformly.
    infinite: Vec<u32>,
    /// Per emitter: whether it is in `infinite`.
    is_infinite: Vec<bool>,
    /// The scene's only light, when it has one (chosen with probability
    /// 1: the general rules give exactly that, after a chain of divisions).
    lone: Option<LightChoice>,
}

/// Lights deeper than this would overflow a trail; the build stops
/// splitting there (SAOH splits keep the depth near log₂ n, so only
/// pathological scenes come close).
const MAX_DEPTH: u32 = 63;

impl LightBvh {
    /// Builds the tree over `emitters` in a scene of bounding radius
    /// `radius`, leaving out those whose `left_out` entry is true (their
    /// probability is 0).
    pub fn new(emitters: &[Emitter], left_out: &[bool], ctx: &EmitterContext, radius: f32) -> Self {
        let mut bvh = LightBvh {
            first_trail: vec![u32::MAX; emitters.len()],
            split: vec![false; emitters.len()],
            is_infinite: vec![false; emitters.len()],
            ..Self::default()
        };
        let mut leaves: Vec<(LightChoice, LightBounds)> = Vec::new();
        let mut trail_count = 0u32;
        for (i, e) in emitters.iter().enumerate() {
            let i = i as u32;
            // Nothing samples a directional area light from a point.
            if matches!(e, Emitter::DirectionalArea(_)) || left_out.get(i as usize) == Some(&true) {
                continue;
            }
            if has_no_bounds(e) {
                if e.power(ctx, radius) > 0.0 {
                    bvh.infinite.push(i);
                    bvh.is_infinite[i as usize] = true;
                }
                continue;
            }
            let before = leaves.len();
            let split = push_bounds(e, i, ctx, radius, &mut leaves);
            bvh.split[i as usize] = split;
            // A light left out for having no power gets no trail slot.
            if split || leaves.len() > before {
                bvh.first_trail[i as usize] = trail_count;
                trail_count += if split { prim_count(e, ctx) } else { 1 };
            }
        }
        bvh.trails = vec![NO_TRAIL; trail_count as usize];
        if !leaves.is_empty() {
            bvh.build(&mut leaves, 0, 0);
        }
        bvh.lone = match (bvh.lights.as_slice(), bvh.infinite.as_slice()) {
            ([light], []) => Some(*light),
            ([], [e]) => Some(LightChoice {
                emitter: *e,
                prim: LightChoice::WHOLE,
            }),
            _ => None,
        };
        bvh
    }

    /// Whether the tree chooses no light at all.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() && self.infinite.is_empty()
    }

    /// Index into `trails` of a light, if it is in the tree.
    fn trail_index(&self, light: LightChoice) -> Option<usize> {
        let first = *self.first_trail.get(light.emitter as usize)?;
        if first == u32::MAX {
            return None;
        }
        let offset = if self.split[light.emitter as usize] {
            if light.prim == LightChoice::WHOLE {
                return None;
            }
            light.prim
        } else {
            0
        };
        Some((first + offset) as usize)
    }

    /// Builds the subtree over `leaves` at `depth` below the root with
    /// `trail`; returns its node index.
    fn build(
        &mut self,
        leaves: &mut [(LightChoice, LightBounds)],
        depth: u32,
        trail: Trail,
    ) -> u32 {
        let node = self.nodes.len() as u32;
        if leaves.len() == 1 || depth >= MAX_DEPTH {
            // At MAX_DEPTH (never reached in practice) the leaf keeps its
            // first light's bounds and the rest are lost to light sampling.
            let (light, lb) = leaves[0];
            self.nodes.push(Node {
                lb,
                index: self.lights.len() as u32,
                leaf: true,
            });
            self.lights.push(light);
            if let Some(t) = self.trail_index(light) {
                self.trails[t] = trail;
            }
            return node;
        }
        let total = leaves[1..]
            .iter()
            .fold(leaves[0].1, |acc, (_, lb)| acc.union(lb));
        self.nodes.push(Node {
            lb: total,
            index: 0,
            leaf: false,
        });
        // Deep down, halve the list instead: the depth then stays below 64 for
        // any number of lights a scene can hold.
        let mid = if depth < 40 {
            split_by_saoh(leaves, &total)
        } else {
            leaves.len() / 2
        };
        let (left, right) = leaves.split_at_mut(mid);
        self.build(left, depth + 1, trail);
        let second = self.build(right, depth + 1, trail | (1u64 << depth));
        self.nodes[node as usize].index = second;
        node
    }

    /// Probability that the tree (not a light at infinity) is chosen.
    fn p_tree(&self) -> f32 {
        if self.nodes.is_empty() {
            0.0
        } else {
            1.0 / (self.infinite.len() + 1) as f32
        }
    }

    /// Chooses a light for point `p` with normal `n`: uniformly among the
    /// tree's lights with probability α, else by traversal (a lone light
    /// inline, without the call).
    #[inline]
    pub fn sample(&self, u: f32, p: Vec3, n: Vec3) -> Option<(LightChoice, f32)> {
        match self.lone {
            Some(light) => Some((light, 1.0)),
            None => self.sample_among(u, p, n),
        }
    }

    /// [`LightBvh::sample`] among several lights.
    #[inline(never)]
    fn sample_among(&self, u: f32, p: Vec3, n: Vec3) -> Option<(LightChoice, f32)> {
        let p_tree = self.p_tree();
        if u < p_tree && !self.nodes.is_empty() {
            let u = u / p_tree;
            let (choice, tree_pmf) = if u < DEFENSIVE_FRACTION {
                let n_lights = self.lights.len();
                let k = ((u / DEFENSIVE_FRACTION) * n_lights as f32) as usize;
                let light = self.lights[k.min(n_lights - 1)];
                (light, self.traversal_pmf(light, p, n))
            } else {
                let u = ((u - DEFENSIVE_FRACTION) / (1.0 - DEFENSIVE_FRACTION)).min(ONE_MINUS_EPS);
                self.traverse(u, p, n)?
            };
            return Some((choice, p_tree * self.mix(tree_pmf)));
        }
        self.sample_infinite(u, p_tree)
    }

    /// The mixture of the traversal's probability with the uniform choice.
    #[inline]
    fn mix(&self, tree_pmf: f32) -> f32 {
        (1.0 - DEFENSIVE_FRACTION) * tree_pmf + DEFENSIVE_FRACTION / self.lights.len() as f32
    }

    /// A light at infinity, for `u` in [p_tree, 1).
    fn sample_infinite(&self, u: f32, p_tree: f32) -> Option<(LightChoice, f32)> {
        if self.infinite.is_empty() {
            return None;
        }
        let p_inf = (1.0 - p_tree) / self.infinite.len() as f32;
        let k = (((u - p_tree) / (1.0 - p_tree)) * self.infinite.len() as f32) as usize;
        let e = self.infinite[k.min(self.infinite.len() - 1)];
        Some((
            LightChoice {
                emitter: e,
                prim: LightChoice::WHOLE,
            },
            p_inf,
        ))
    }

    /// Walks down the tree with `u`, each child taken in proportion to its
    /// importance: the leaf's light and the product of the probabilities.
    fn traverse(&self, mut u: f32, p: Vec3, n: Vec3) -> Option<(LightChoice, f32)> {
        let mut pmf = 1.0;
        let mut i = 0usize;
        loop {
            let node = &self.nodes[i];
            // A leaf below the root was weighed as its parent's child (a
            // child without importance is never taken); a lone light is
            // always chosen, as a light it cannot reach adds nothing.
            if node.leaf {
                return Some((self.lights[node.index as usize], pmf));
            }
            let (a, b, pa) = self.children(i, p, n)?;
            if u < pa {
                u = (u / pa).min(ONE_MINUS_EPS);
                pmf *= pa;
                i = a;
            } else {
                u = ((u - pa) / (1.0 - pa)).min(ONE_MINUS_EPS);
                pmf *= 1.0 - pa;
                i = b;
            }
        }
    }

    /// The children of interior node `i` and the probability of taking
    /// the first at (`p`, `n`); `None` when neither has any importance.
    #[inline]
    fn children(&self, i: usize, p: Vec3, n: Vec3) -> Option<(usize, usize, f32)> {
        let (a, b) = (i + 1, self.nodes[i].index as usize);
        let ia = self.nodes[a].lb.importance(p, n);
        let ib = self.nodes[b].lb.importance(p, n);
        (ia + ib > 0.0).then(|| (a, b, ia / (ia + ib)))
    }

    /// Probability that [`LightBvh::sample`] at (`p`, `n`) chooses `light`.
    pub fn pmf(&self, light: LightChoice, p: Vec3, n: Vec3) -> f32 {
        if self.lone == Some(light) {
            return 1.0;
        }
        let e = light.emitter as usize;
        if self.is_infinite.get(e).copied().unwrap_or(false) {
            return (1.0 - self.p_tree()) / self.infinite.len() as f32;
        }
        match self.trail_index(light) {
            Some(t) if self.trails[t] != NO_TRAIL => {
                self.p_tree() * self.mix(self.traversal_pmf(light, p, n))
            }
            _ => 0.0,
        }
    }

    /// Probability that the traversal alone reaches `light` (a light of
    /// the tree) from (`p`, `n`), following its bit trail.
    fn traversal_pmf(&self, light: LightChoice, p: Vec3, n: Vec3) -> f32 {
        let Some(t) = self.trail_index(light) else {
            return 0.0;
        };
        let trail = self.trails[t];
        let mut pmf = 1.0;
        let mut i = 0usize;
        for depth in 0..MAX_DEPTH {
            let node = &self.nodes[i];
            if node.leaf {
                return pmf;
            }
            let Some((a, b, pa)) = self.children(i, p, n) else {
                return 0.0;
            };
            if trail >> depth & 1 == 0 {
                pmf *= pa;
                i = a;
            } else {
                pmf *= 1.0 - pa;
                i = b;
            }
        }
        0.0
    }

    /// Number of lights in the tree (leaves).
    pub fn light_count(&self) -> usize {
        self.lights.len()
    }

    /// Whether `emitter`'s mesh triangles are separate lights.
    pub fn splits(&self, emitter: u32) -> bool {
        self.split.get(emitter as usize).copied().unwrap_or(false)
    }
}

const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// α, the share of light choices made uniformly among the tree's lights
/// (see the module docs).
pub const DEFENSIVE_FRACTION: f32 = 0.25;

/// Lights the tree cannot bound.
fn has_no_bounds(e: &Emitter) -> bool {
    e.is_environment() || matches!(e, Emitter::Directional(_))
}

fn prim_count(e: &Emitter, ctx: &EmitterContext) -> u32 {
    match e {
        Emitter::Area(a) => ctx.shapes[a.shape as usize].prim_count(ctx.meshes),
        _ => 1,
    }
}

/// Appends the tree's lights for emitter `e` (index `i`): one, or one
/// per triangle of an emissive mesh (then returns true). Lights without
/// power are left out.
fn push_bounds(
    e: &Emitter,
    i: u32,
    ctx: &EmitterContext,
    radius: f32,
    out: &mut Vec<(LightChoice, LightBounds)>,
) -> bool {
    let whole = LightChoice {
        emitter: i,
        prim: LightChoice::WHOLE,
    };
    let mut push = |light, lb: LightBounds| {
        if lb.phi > 0.0 && lb.phi.is_finite() {
            out.push((light, lb));
        }
    };
    match e {
        Emitter::Area(a) => {
            let shape = &ctx.shapes[a.shape as usize];
            let mean = super::power_mean(a.radiance, ctx.materials);
            if let Shape::Mesh(m) = shape {
                let mesh = &ctx.meshes[m.mesh as usize];
                for tri in 0..mesh.triangle_count() {
                    let (w, cos_theta_o) = mesh.triangle_normal_cone(tri);
                    push(
                        LightChoice {
                            emitter: i,
                            prim: tri as u32,
                        },
                        LightBounds {
                            bounds: Bounds3::from_points(mesh.triangle(tri)),
                            phi: PI * mean * mesh.triangle_area(tri),
                            w,
                            cos_theta_o,
                            cos_theta_e: 0.0,
                            two_sided: false,
                        },
                    );
                }
                return true;
            }
            let bounds = (0..shape.prim_count(ctx.meshes))
                .map(|p| shape.prim_bounds(ctx.meshes, p))
                .fold(Bounds3::EMPTY, Bounds3::union);
            let (w, cos_theta_o) = match shape {
                Shape::Rectangle(r) => (front_normal(&r.to_world, r.flip_normals), 1.0),
                Shape::Disk(d) => (front_normal(&d.to_world, d.flip_normals), 1.0),
                // Spheres and cylinders emit every way.
                _ => (Vec3::Z, -1.0),
            };
            push(
                whole,
                LightBounds {
                    bounds,
                    phi: e.power(ctx, radius),
                    w,
                    cos_theta_o,
                    cos_theta_e: 0.0,
                    two_sided: false,
                },
            );
        }
        Emitter::Point(l) => push(
            whole,
            LightBounds {
                bounds: Bounds3::from_point(l.position),
                phi: e.power(ctx, radius),
                w: Vec3::Z,
                cos_theta_o: -1.0,
                cos_theta_e: 0.0,
                two_sided: false,
            },
        ),
        Emitter::Spot(s) => push(
            whole,
            beam_bounds(&s.to_world, s.cutoff.cos(), e.power(ctx, radius)),
        ),
        Emitter::Projector(l) => push(
            whole,
            beam_bounds(&l.to_world, l.cos_half_diagonal(), e.power(ctx, radius)),
        ),
        _ => {}
    }
    false
}

/// Bounds of a light at the origin of `to_world` that shines into the cone
/// of half-angle cosine `cos_theta_e` about its +z axis (`spot`,
/// `projector`), with power `phi`.
fn beam_bounds(to_world: &crate::math::Transform, cos_theta_e: f32, phi: f32) -> LightBounds {
    LightBounds {
        bounds: Bounds3::from_point(to_world.point(Vec3::ZERO)),
        phi,
        w: to_world.vector(Vec3::Z).normalize(),
        cos_theta_o: 1.0,
        cos_theta_e,
        two_sided: false,
    }
}

/// The emitting side's normal of a planar shape (object +z).
fn front_normal(to_world: &crate::math::Transform, flip: bool) -> Vec3 {
    let n = to_world.normal(Vec3::Z).normalize_or_zero();
    if flip {
        -n
    } else {
        n
    }
}

/// The surface area orientation heuristic's normal-cone measure M_Ω
/// (Conty Estevez & Kulla 2018, eq. 1 and its closed form).
fn orientation_measure(lb: &LightBounds) -> f32 {
    let theta_o = lb.cos_theta_o.clamp(-1.0, 1.0).acos();
    let theta_e = lb.cos_theta_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(PI);
    let (sin_o, cos_o) = theta_o.sin_cos();
    2.0 * PI * (1.0 - cos_o)
        + FRAC_PI_2
            * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                + cos_o)
}

/// Sorts `leaves` so that the best split (SAOH, 12 bins per axis of the
/// centroids) divides them, and returns where.
fn split_by_saoh(leaves: &mut [(LightChoice, LightBounds)], total: &LightBounds) -> usize {
    const BINS: usize = 12;
    let centroids = leaves.iter().fold(Bounds3::EMPTY, |b, (_, lb)| {
        b.union_point(lb.bounds.center())
    });
    let extent = total.bounds.extent();
    let max_extent = extent.max_element();
    let mut best: Option<(f32, usize, f32)> = None;
    for axis in 0..3 {
        let (lo, hi) = (centroids.min[axis], centroids.max[axis]);
        if hi <= lo {
            continue;
        }
        let bin_of = |lb: &LightBounds| {
            let b = ((lb.bounds.center()[axis] - lo) / (hi - lo) * BINS as f32) as usize;
            b.min(BINS - 1)
        };
        let mut bins: [Option<LightBounds>; BINS] = [None; BINS];
        for (_, lb) in leaves.iter() {
            let slot = &mut bins[bin_of(lb)];
            *slot = Some(slot.map_or(*lb, |b| b.union(lb)));
        }
        // Aspect-ratio factor: thin splits across the long axis are cheap.
        let kr = if extent[axis] > 0.0 {
            max_extent / extent[axis]
        } else {
            1.0
        };
        let cost = |lb: &Option<LightBounds>| {
            lb.map_or(0.0, |lb| {
                lb.phi * orientation_measure(&lb) * lb.bounds.surface_area().max(1e-12)
            })
        };
        for split in 1..BINS {
            let merge = |range: std::ops::Range<usize>| {
                bins[range]
                    .iter()
                    .flatten()
                    .fold(None, |acc: Option<LightBounds>, b| {
                        Some(acc.map_or(*b, |a| a.union(b)))
                    })
            };
            let c = kr * (cost(&merge(0..split)) + cost(&merge(split..BINS)));
            if best.is_none_or(|(bc, ..)| c < bc) {
                best = Some((c, axis, lo + (hi - lo) * split as f32 / BINS as f32));
            }
        }
    }
    let mid = match best {
        Some((_, axis, at)) => partition(leaves, |lb| lb.bounds.center()[axis] < at),
        None => 0,
    };
    if mid == 0 || mid == leaves.len() {
        // Coincident centroids (or a degenerate split): halve the list.
        leaves.len() / 2
    } else {
        mid
    }
}

/// Moves the leaves for which `left` holds to the front; returns how many.
fn partition(
    leaves: &mut [(LightChoice, LightBounds)],
    left: impl Fn(&LightBounds) -> bool,
) -> usize {
    let mut i = 0;
    for j in 0..leaves.len() {
        if left(&leaves[j].1) {
            leaves.swap(i, j);
            i += 1;
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::{ConstantLight, LightSampler, LightSelection, PointLight, SpotLight};
    use crate::math::Transform;
    use crate::render::{LightOptions, RenderScene, RenderState};
    use crate::sampler::Pcg32;
    use crate::sampling::square_to_uniform_sphere;
    use crate::shape::{cube::cube_mesh, MeshShape, Rectangle, Sphere};
    use crate::testing::chi2::chi2_discrete;
    use crate::texture::Tex;
    use crate::{Rgb, Scene, SceneBuilder};
    use glam::Affine3A;

    /// Lights of every kind the tree holds, and one at infinity, with a
    /// render's state that chooses them by the light BVH.
    fn many_light_scene() -> (Scene, RenderState) {
        let mut b = SceneBuilder::new();
        let mesh = b.add_mesh(cube_mesh());
        let glow = Some(Tex::Const(Rgb::splat(2.0)));
        b.add_shape(Shape::Mesh(MeshShape { mesh }), None, glow)
            .unwrap();
        for (i, angle) in [0.3f32, 2.0, -1.2].into_iter().enumerate() {
            let to_world = Transform::new(
                Affine3A::from_translation(Vec3::new(3.0 * i as f32 - 3.0, 2.0, 1.0))
                    * Affine3A::from_rotation_x(angle),
            )
            .unwrap();
            let rect = Shape::Rectangle(Rectangle::new(to_world, false));
            b.add_shape(rect, None, Some(Tex::Const(Rgb::splat(1.0 + i as f32))))
                .unwrap();
        }
        let sphere = Sphere::new(Vec3::new(0.0, -3.0, 0.5), 0.5, false);
        b.add_shape(Shape::Sphere(sphere), None, glow).unwrap();
        b.add_emitter(Emitter::Point(PointLight {
            position: Vec3::new(1.0, 1.0, 4.0),
            intensity: Rgb::splat(5.0),
        }));
        let spot_to_world = Transform::new(
            Affine3A::from_translation(Vec3::new(-2.0, 0.0, 3.0)) * Affine3A::from_rotation_y(0.4),
        )
        .unwrap();
        b.add_emitter(Emitter::Spot(SpotLight::new(
            spot_to_world,
            Rgb::splat(10.0),
            0.5,
            0.3,
        )));
        b.add_emitter(Emitter::Constant(ConstantLight {
            radiance: Rgb::splat(0.1),
        }));
        let scene = b.build().unwrap();
        let lights = LightOptions {
            selection: LightSelection::Bvh,
            mis_compensation: false,
        };
        let state = RenderState::with_lights(&scene, lights);
        (scene, state)
    }

    /// Every light the sampler can return, as it names them.
    fn all_choices(scene: &RenderScene) -> Vec<LightChoice> {
        let ctx = scene.emitter_context();
        let mut out = Vec::new();
        for (i, e) in scene.emitters.iter().enumerate() {
            let emitter = i as u32;
            if scene.light_sampler().splits(emitter) {
                for prim in 0..prim_count(e, &ctx) {
                    out.push(LightChoice { emitter, prim });
                }
            } else {
                out.push(LightChoice {
                    emitter,
                    prim: LightChoice::WHOLE,
                });
            }
        }
        out
    }

    #[test]
    fn light_bvh_choices_sum_to_one_and_match_their_pmf() {
        let (scene, state) = many_light_scene();
        let sampler: &LightSampler = state.light_sampler();
        let choices = all_choices(&RenderScene::new(&scene, &state));
        assert_eq!(choices.len(), 12 + 3 + 1 + 3, "cube triangles one by one");
        let mut rng = Pcg32::new(7, 1);
        for case in 0..6 {
            let p = Vec3::new(
                rng.next_f32() * 8.0 - 4.0,
                rng.next_f32() * 8.0 - 4.0,
                rng.next_f32() * 4.0 - 1.0,
            );
            // A point without a normal (the camera, a medium) half the time.
            let n = if case % 2 == 0 {
                square_to_uniform_sphere(rng.next_2d())
            } else {
                Vec3::ZERO
            };
            let pmf: Vec<f64> = choices
                .iter()
                .map(|&c| sampler.pmf(c, p, n) as f64)
                .collect();
            // Below a node whose children both have no importance, the
            // choice fails (no light): the pmfs sum to less than one by the
            // probability of failing, counted in a last bin.
            let total: f64 = pmf.iter().sum();
            assert!(
                total <= 1.0 + 1e-4 && total > 0.3,
                "case {case}: pmfs sum to {total}"
            );
            let mut counts = vec![0u64; choices.len() + 1];
            let draws = 200_000;
            for _ in 0..draws {
                let Some((c, reported)) = sampler.sample(rng.next_f32(), p, n) else {
                    counts[choices.len()] += 1;
                    continue;
                };
                let k = choices.iter().position(|&x| x == c).unwrap();
                let expected = pmf[k] as f32;
                assert!(
                    (reported - expected).abs() <= 1e-4 * expected.max(1e-3),
                    "case {case}: {c:?} reported {reported}, pmf {expected}"
                );
                counts[k] += 1;
            }
            let expected: Vec<f64> = pmf
                .iter()
                .chain([&(1.0 - total).max(0.0)])
                .map(|q| q * draws as f64)
                .collect();
            chi2_discrete(&counts, &expected, 0.01).unwrap_or_else(|e| panic!("case {case}: {e}"));
        }
    }

    #[test]
    fn light_bvh_prefers_the_near_light() {
        let (scene, state) = many_light_scene();
        let choices = all_choices(&RenderScene::new(&scene, &state));
        // Just in front of the first rectangle: it outweighs the others.
        let rect_emitter = 1;
        let to_world = match scene.shapes[1] {
            Shape::Rectangle(r) => r.to_world,
            _ => unreachable!(),
        };
        let front = to_world.normal(Vec3::Z).normalize();
        let p = to_world.point(Vec3::ZERO) + 0.05 * front;
        let near = state.light_sampler().pmf(
            LightChoice {
                emitter: rect_emitter,
                prim: LightChoice::WHOLE,
            },
            p,
            -front,
        );
        // Seen from in front of the third rectangle, three units away, the
        // first gets fewer samples.
        let third = match scene.shapes[3] {
            Shape::Rectangle(r) => r.to_world,
            _ => unreachable!(),
        };
        let third_front = third.normal(Vec3::Z).normalize();
        let far_p = third.point(Vec3::ZERO) + 0.05 * third_front;
        let far = state.light_sampler().pmf(
            LightChoice {
                emitter: rect_emitter,
                prim: LightChoice::WHOLE,
            },
            far_p,
            -third_front,
        );
        assert!(near > 2.0 * far, "near {near}, far {far}");
        let _ = &choices;
        // Well behind a one-sided light (outside its bounding sphere), the
        // tree never takes it: only the uniform share α / n chooses it.
        let behind = to_world.point(Vec3::ZERO) - 3.0 * front;
        let pmf_behind = state.light_sampler().pmf(
            LightChoice {
                emitter: rect_emitter,
                prim: LightChoice::WHOLE,
            },
            behind,
            front,
        );
        let tree_lights = state.light_sampler().bvh_light_count() as f32;
        let p_tree = 1.0 / (1 + scene.environment_emitters.len()) as f32;
        let floor = p_tree * DEFENSIVE_FRACTION / tree_lights;
        assert!(
            (pmf_behind / floor - 1.0).abs() < 1e-5,
            "{pmf_behind} vs {floor}"
        );
        assert!(near > 10.0 * floor);
    }

    /// Under MIS compensation every strategy leaves a `constant` emitter to
    /// BSDF sampling (probability 0, never chosen) and gives its share to
    /// the other lights; one hidden from indirect rays is still chosen.
    #[test]
    fn compensation_leaves_constant_emitters_to_bsdf_sampling() {
        use crate::light::EmitterOptions;
        let (p, n) = (Vec3::new(0.5, 0.2, 1.0), Vec3::Z);
        for selection in [
            LightSelection::Uniform,
            LightSelection::Power,
            LightSelection::Bvh,
        ] {
            for visible_indirect in [true, false] {
                let mut b = SceneBuilder::new();
                b.add_emitter(Emitter::Point(PointLight {
                    position: Vec3::new(1.0, 1.0, 4.0),
                    intensity: Rgb::splat(5.0),
                }));
                let sky = b.add_emitter(Emitter::Constant(ConstantLight {
                    radiance: Rgb::splat(0.1),
                }));
                let options = EmitterOptions {
                    visible_indirect,
                    ..EmitterOptions::default()
                };
                b.set_emitter_options(sky, options);
                let scene = b.build().unwrap();
                let lights = LightOptions {
                    selection,
                    mis_compensation: true,
                };
                let state = RenderState::with_lights(&scene, lights);
                let sky = LightChoice {
                    emitter: sky,
                    prim: LightChoice::WHOLE,
                };
                let point = LightChoice { emitter: 0, ..sky };
                let sampler = state.light_sampler();
                let (sky_pmf, point_pmf) = (sampler.pmf(sky, p, n), sampler.pmf(point, p, n));
                let mut rng = Pcg32::new(5, 9);
                let picked_sky = (0..1000)
                    .filter(|_| sampler.sample(rng.next_f32(), p, n).unwrap().0 == sky)
                    .count();
                let case = format!("{selection:?}, visible_indirect {visible_indirect}");
                if visible_indirect {
                    assert_eq!((sky_pmf, point_pmf, picked_sky), (0.0, 1.0, 0), "{case}");
                } else {
                    assert!(
                        sky_pmf > 0.05 && picked_sky > 20,
                        "{case}: {sky_pmf}, {picked_sky}"
                    );
                }
            }
        }
        // A light of sampling weight 0 beside the sky is never sampled,
        // with or without compensation (Mitsuba's rule); only when every
        // weight is 0 do the lights share uniformly.
        for (point_weight, sampled) in [(0.0, false), (1.0, true)] {
            let mut b = SceneBuilder::new();
            let point = b.add_emitter(Emitter::Point(PointLight {
                position: Vec3::new(1.0, 1.0, 4.0),
                intensity: Rgb::splat(5.0),
            }));
            b.set_emitter_options(
                point,
                EmitterOptions {
                    sampling_weight: point_weight,
                    ..EmitterOptions::default()
                },
            );
            b.add_emitter(Emitter::Constant(ConstantLight {
                radiance: Rgb::splat(0.1),
            }));
            let scene = b.build().unwrap();
            let lights = LightOptions {
                selection: LightSelection::Uniform,
                mis_compensation: true,
            };
            let state = RenderState::with_lights(&scene, lights);
            let got = state.light_sampler().sample(0.5, p, n).is_some();
            assert_eq!(got, sampled, "point light of weight {point_weight}");
        }
    }

    #[test]
    fn cone_union_contains_both_cones() {
        let mut rng = Pcg32::new(3, 3);
        for _ in 0..1000 {
            let wa = square_to_uniform_sphere(rng.next_2d());
            let wb = square_to_uniform_sphere(rng.next_2d());
            let (ta, tb) = (rng.next_f32() * 1.5, rng.next_f32() * 1.5);
            let (w, t) = cone_union(wa, ta, wb, tb);
            if t >= PI {
                continue;
            }
            for (axis, theta) in [(wa, ta), (wb, tb)] {
                let angle = w.dot(axis).clamp(-1.0, 1.0).acos();
                // acos near 1 loses precision: a milliradian of slack.
                assert!(angle + theta <= t + 1e-3, "{angle} + {theta} > {t}");
            }
        }
    }
}
