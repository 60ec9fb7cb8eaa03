//! The nodes of an `sdf` shape's distance function: `<sdf type="...">`
//! elements nested in `<shape type="sdf">` and in one another.
//!
//! Primitives (formulas from Quilez, "distance functions",
//! iquilezles.org/articles/distfunctions; all exact distances):
//!
//! | type        | parameters (defaults)                                            | shape |
//! |-------------|------------------------------------------------------------------|-------|
//! | `sphere`    | `center` point (0, 0, 0), `radius` (1)                           | ball |
//! | `box`       | `center` point (0, 0, 0), `half_size` vector (1, 1, 1)           | box, as Mitsuba's `cube` by default |
//! | `round_box` | `half_size` vector (1, 1, 1), `radius` (0.1)                     | box of the same outer size with edges rounded by `radius` |
//! | `torus`     | `major_radius` (1), `minor_radius` (0.25)                        | ring around the z axis |
//! | `cylinder`  | `p0` (0, 0, 0), `p1` (0, 0, 1), `radius` (1)                     | solid cylinder with flat caps (Mitsuba's `cylinder` plus its two end disks) |
//! | `capsule`   | `p0` (0, 0, 0), `p1` (0, 0, 1), `radius` (0.5)                   | segment swept by a ball |
//! | `plane`     | `normal` vector (0, 0, 1), `offset` (0)                          | half-space n·p < offset (unbounded) |
//! | `hex_prism` | `radius` (1, centre to the flat sides), `half_height` (0.5)      | hexagonal bar along z |
//! | `mandelbox` | see the `mandelbox` plugin                                       | the fractal |
//!
//! Operations, on the nested `<sdf>` elements in order:
//!
//! | type                  | parameters | result |
//! |-----------------------|------------|--------|
//! | `union`               |            | min of all |
//! | `intersection`        |            | max of all |
//! | `difference`          |            | the first minus all the others |
//! | `smooth_union`        | `k` (0.1)  | Quilez's quadratic smooth minimum: surfaces blend within distance `k` |
//! | `smooth_intersection` | `k` (0.1)  | −smin(−a, −b) |
//! | `smooth_difference`   | `k` (0.1)  | −smin(−a, b) |
//! | `repeat`              | `cell` vector; `limit` vector (absent: infinite) | one child repeated every `cell` along each axis whose cell is positive, −limit … +limit copies when `limit` is given (Quilez's finite repetition) |
//! | `round`               | `radius`   | d − radius: the surface grown outward, edges rounded |
//! | `onion`               | `thickness`| \|d\| − thickness: a shell |
//!
//! Every node takes a `to_world` transform. A transform that scales
//! unevenly is not an isometry: the distance is multiplied by the
//! smallest singular value of its linear part, which keeps it a lower
//! bound (the marcher never steps through the surface), at the cost of
//! shorter steps.
//!
//! ```xml
//! <shape type="sdf">
//!     <sdf type="smooth_difference">
//!         <float name="k" value="0.05"/>
//!         <sdf type="round_box"><vector name="half_size" value="1, 1, 1"/></sdf>
//!         <sdf type="sphere"><float name="radius" value="1.25"/></sdf>
//!     </sdf>
//! </shape>
//! ```
//!
//! **Exactness.** Union, the smooth operations and `repeat` give lower
//! bounds of the distance, not the distance, inside the blended or
//! repeated region; `repeat` is a bound only when the child fits inside
//! its cell symmetrically (a rotated bar that leans into its neighbour
//! cell is not): lower `step_factor` on the shape for those (seed 000
//! used 0.75 for rotated repeated bars).
//!
//! A tree is stored once for the program's life (interned by content,
//! like `roughplastic`'s tables), so that the shape that refers to it
//! stays a small `Copy` value in the scene's shape table.

use super::mandelbox::Mandelbox;
use crate::math::{Bounds3, Transform};
use crate::params::{Family, ParamError, Params};
use glam::{Affine3A, DMat3, Vec2, Vec3};
use std::sync::Mutex;

/// At most this many nodes nest inside one another (the evaluation
/// recurses once per level).
pub const MAX_DEPTH: usize = 64;
/// At most this many nodes in one tree.
pub const MAX_NODES: usize = 4096;

/// How two distances combine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    /// min(a, b).
    Union,
    /// max(a, b).
    Intersection,
    /// max(a, −b).
    Difference,
    /// Quilez's quadratic smooth minimum with blend radius k.
    SmoothUnion(f32),
    /// −smin(−a, −b).
    SmoothIntersection(f32),
    /// −smin(−a, b).
    SmoothDifference(f32),
}

/// One node of a distance function; children are indices into the tree.
// The fields are the parameters of the module's tables, by name.
#[allow(missing_docs)]
#[derive(Clone, Debug, PartialEq)]
pub enum Node {
    /// A ball.
    Sphere { center: Vec3, radius: f32 },
    /// An axis-aligned box.
    Box { center: Vec3, half: Vec3 },
    /// A box with rounded edges (outer size `half`).
    RoundBox { half: Vec3, radius: f32 },
    /// A ring around z.
    Torus { major: f32, minor: f32 },
    /// A capped cylinder from `a` to `b`.
    Cylinder { a: Vec3, b: Vec3, radius: f32 },
    /// A capsule from `a` to `b`.
    Capsule { a: Vec3, b: Vec3, radius: f32 },
    /// The half-space n·p < offset.
    Plane { normal: Vec3, offset: f32 },
    /// A hexagonal prism along z.
    HexPrism { radius: f32, half_height: f32 },
    /// The Mandelbox fractal.
    Mandelbox(Mandelbox),
    /// Two children combined.
    Combine { op: Op, a: u32, b: u32 },
    /// A child repeated over a lattice (`limit` copies each way, or all).
    Repeat {
        child: u32,
        cell: Vec3,
        limit: Option<Vec3>,
    },
    /// d − radius.
    Round { child: u32, radius: f32 },
    /// |d| − thickness.
    Onion { child: u32, thickness: f32 },
    /// A child placed by `to_world`; distances scaled by `scale`, the
    /// smallest singular value of its linear part.
    Placed {
        child: u32,
        to_world: Affine3A,
        to_local: Affine3A,
        scale: f32,
    },
}

/// A whole distance function: its nodes, the root last.
#[derive(Clone, Debug, PartialEq)]
pub struct SdfTree {
    nodes: Vec<Node>,
}

static INTERNED: Mutex<Vec<&'static SdfTree>> = Mutex::new(Vec::new());

impl SdfTree {
    /// A tree of one node.
    pub fn single(node: Node) -> Self {
        Self { nodes: vec![node] }
    }

    /// A tree of `nodes`, the root last; children come before parents.
    pub(crate) fn from_nodes(nodes: Vec<Node>) -> Self {
        Self { nodes }
    }

    /// The tree stored for the program's life: the same content is stored
    /// once.
    pub fn interned(self) -> &'static SdfTree {
        super::interned(&INTERNED, self)
    }

    /// The nodes, the root last.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    fn root(&self) -> u32 {
        self.nodes.len() as u32 - 1
    }

    /// The signed distance (or a lower bound of it) at `p`.
    #[inline]
    pub fn distance(&self, p: Vec3) -> f32 {
        self.eval(self.root(), p)
    }

    fn eval(&self, i: u32, p: Vec3) -> f32 {
        match &self.nodes[i as usize] {
            Node::Sphere { center, radius } => (p - *center).length() - radius,
            Node::Box { center, half } => box_distance(p - *center, *half),
            Node::RoundBox { half, radius } => {
                box_distance(p, *half - Vec3::splat(*radius)) - radius
            }
            Node::Torus { major, minor } => {
                Vec2::new(Vec2::new(p.x, p.y).length() - major, p.z).length() - minor
            }
            Node::Cylinder { a, b, radius } => capped_cylinder(p, *a, *b, *radius),
            Node::Capsule { a, b, radius } => {
                let (pa, ba) = (p - *a, *b - *a);
                let h = (pa.dot(ba) / ba.dot(ba)).clamp(0.0, 1.0);
                (pa - ba * h).length() - radius
            }
            Node::Plane { normal, offset } => p.dot(*normal) - offset,
            Node::HexPrism {
                radius,
                half_height,
            } => hex_prism(p, *radius, *half_height),
            Node::Mandelbox(m) => m.distance(p),
            Node::Combine { op, a, b } => combine(*op, self.eval(*a, p), self.eval(*b, p)),
            Node::Repeat { child, cell, limit } => self.eval(*child, repeat(p, *cell, *limit)),
            Node::Round { child, radius } => self.eval(*child, p) - radius,
            Node::Onion { child, thickness } => self.eval(*child, p).abs() - thickness,
            Node::Placed {
                child,
                to_local,
                scale,
                ..
            } => self.eval(*child, to_local.transform_point3(p)) * scale,
        }
    }

    /// A box holding the surface (infinite along unbounded axes).
    pub fn bounds(&self) -> Bounds3 {
        self.node_bounds(self.root())
    }

    fn node_bounds(&self, i: u32) -> Bounds3 {
        let around = |c: Vec3, h: Vec3| Bounds3 {
            min: c - h,
            max: c + h,
        };
        let segment = |a: Vec3, b: Vec3, r: f32| Bounds3::from_points([a, b]).expanded(r);
        match &self.nodes[i as usize] {
            Node::Sphere { center, radius } => around(*center, Vec3::splat(*radius)),
            Node::Box { center, half } => around(*center, *half),
            Node::RoundBox { half, .. } => around(Vec3::ZERO, *half),
            Node::Torus { major, minor } => {
                around(Vec3::ZERO, Vec3::new(major + minor, major + minor, *minor))
            }
            Node::Cylinder { a, b, radius } | Node::Capsule { a, b, radius } => {
                segment(*a, *b, *radius)
            }
            Node::Plane { .. } => INFINITE,
            Node::HexPrism {
                radius,
                half_height,
            } => {
                let corner = radius * 2.0 / 3f32.sqrt();
                around(Vec3::ZERO, Vec3::new(corner, corner, *half_height))
            }
            Node::Mandelbox(m) => around(Vec3::ZERO, Vec3::splat(m.half_extent())),
            Node::Combine { op, a, b } => {
                let (ba, bb) = (self.node_bounds(*a), self.node_bounds(*b));
                match op {
                    Op::Union => ba.union(bb),
                    Op::SmoothUnion(k) => ba.union(bb).expanded(k / 4.0),
                    Op::Intersection | Op::SmoothIntersection(_) => intersect(ba, bb),
                    Op::Difference | Op::SmoothDifference(_) => ba,
                }
            }
            Node::Repeat { child, cell, limit } => {
                let b = self.node_bounds(*child);
                let reach = match limit {
                    Some(l) => *cell * *l,
                    None => Vec3::select(cell.cmpgt(Vec3::ZERO), Vec3::INFINITY, Vec3::ZERO),
                };
                Bounds3 {
                    min: b.min - reach,
                    max: b.max + reach,
                }
            }
            Node::Round { child, radius } => self.node_bounds(*child).expanded(*radius),
            Node::Onion { child, thickness } => self.node_bounds(*child).expanded(*thickness),
            Node::Placed {
                child, to_world, ..
            } => {
                let b = self.node_bounds(*child);
                if !(b.min.is_finite() && b.max.is_finite()) {
                    return INFINITE;
                }
                Bounds3::from_points(b.corners().map(|c| to_world.transform_point3(c)))
            }
        }
    }
}

const INFINITE: Bounds3 = Bounds3 {
    min: Vec3::NEG_INFINITY,
    max: Vec3::INFINITY,
};

fn intersect(a: Bounds3, b: Bounds3) -> Bounds3 {
    Bounds3 {
        min: a.min.max(b.min),
        max: a.max.min(b.max),
    }
}

trait Expand {
    fn expanded(self, by: f32) -> Self;
}

impl Expand for Bounds3 {
    fn expanded(self, by: f32) -> Self {
        Bounds3 {
            min: self.min - Vec3::splat(by),
            max: self.max + Vec3::splat(by),
        }
    }
}

#[inline]
fn box_distance(p: Vec3, half: Vec3) -> f32 {
    let q = p.abs() - half;
    q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
}

/// Exact distance to a capped cylinder (Quilez, "capped cylinder,
/// arbitrary orientation").
#[inline]
fn capped_cylinder(p: Vec3, a: Vec3, b: Vec3, r: f32) -> f32 {
    let (ba, pa) = (b - a, p - a);
    let baba = ba.dot(ba);
    let paba = pa.dot(ba);
    let x = (pa * baba - ba * paba).length() - r * baba;
    let y = (paba - baba * 0.5).abs() - baba * 0.5;
    let (x2, y2) = (x * x, y * y * baba);
    let d = if x.max(y) < 0.0 {
        -x2.min(y2)
    } else {
        (if x > 0.0 { x2 } else { 0.0 }) + (if y > 0.0 { y2 } else { 0.0 })
    };
    d.signum() * d.abs().sqrt() / baba
}

/// Exact distance to a hexagonal prism along z whose flat sides are at
/// `radius` from the axis (Quilez, "hexagonal prism").
#[inline]
fn hex_prism(p: Vec3, radius: f32, half_height: f32) -> f32 {
    const K: Vec3 = Vec3::new(-0.866_025_4, 0.5, 0.577_350_26);
    let p = p.abs();
    let k = Vec2::new(K.x, K.y);
    let xy = Vec2::new(p.x, p.y);
    let xy = xy - 2.0 * k.dot(xy).min(0.0) * k;
    let edge = Vec2::new(xy.x.clamp(-K.z * radius, K.z * radius), radius);
    let d = Vec2::new(
        (xy - edge).length() * (xy.y - radius).signum(),
        p.z - half_height,
    );
    d.x.max(d.y).min(0.0) + d.max(Vec2::ZERO).length()
}

/// Quilez's quadratic polynomial smooth minimum: below min(a, b) by at
/// most k/4, equal to it where |a − b| ≥ k. Its gradient is a convex
/// combination of the two gradients, so it stays 1-Lipschitz.
#[inline]
pub fn smooth_min(a: f32, b: f32, k: f32) -> f32 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

#[inline]
fn combine(op: Op, a: f32, b: f32) -> f32 {
    match op {
        Op::Union => a.min(b),
        Op::Intersection => a.max(b),
        Op::Difference => a.max(-b),
        Op::SmoothUnion(k) => smooth_min(a, b, k),
        Op::SmoothIntersection(k) => -smooth_min(-a, -b, k),
        Op::SmoothDifference(k) => -smooth_min(-a, b, k),
    }
}

/// The point of the repeated cell that `p` falls in, relative to its
/// centre; axes whose cell is 0 are not repeated.
#[inline]
fn repeat(p: Vec3, cell: Vec3, limit: Option<Vec3>) -> Vec3 {
    let safe = Vec3::select(cell.cmpgt(Vec3::ZERO), cell, Vec3::ONE);
    let mut index = (p / safe).round();
    if let Some(l) = limit {
        index = index.clamp(-l, l);
    }
    let index = Vec3::select(cell.cmpgt(Vec3::ZERO), index, Vec3::ZERO);
    p - cell * index
}

/// The smallest singular value of the linear part of `m`: the factor by
/// which `m` shrinks distances at most. From the eigenvalues of MᵀM
/// (closed form for a symmetric 3×3, Smith 1961).
pub fn min_singular_value(m: &Affine3A) -> f32 {
    let a = DMat3::from_cols(
        m.matrix3.x_axis.as_dvec3(),
        m.matrix3.y_axis.as_dvec3(),
        m.matrix3.z_axis.as_dvec3(),
    );
    let s = a.transpose() * a;
    let (a11, a22, a33) = (s.x_axis.x, s.y_axis.y, s.z_axis.z);
    let (a12, a13, a23) = (s.y_axis.x, s.z_axis.x, s.z_axis.y);
    let p1 = a12 * a12 + a13 * a13 + a23 * a23;
    let lambda_min = if p1 <= 1e-30 * (a11 * a11 + a22 * a22 + a33 * a33) {
        a11.min(a22).min(a33)
    } else {
        let q = (a11 + a22 + a33) / 3.0;
        let p2 = (a11 - q).powi(2) + (a22 - q).powi(2) + (a33 - q).powi(2) + 2.0 * p1;
        let p = (p2 / 6.0).sqrt();
        let b = (s - DMat3::from_diagonal(glam::DVec3::splat(q))) * (1.0 / p);
        let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
        let phi = r.acos() / 3.0;
        q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos()
    };
    // Rounded down a little: the result must not exceed the true value.
    (lambda_min.max(0.0).sqrt() * (1.0 - 1e-6)) as f32
}

/// Builds the tree of `<sdf>` elements nested in `p` (several are
/// united); `None` when there are none.
pub fn tree_from_params(p: &mut dyn Params) -> Result<Option<SdfTree>, ParamError> {
    let mut nodes = Vec::new();
    let Some(root) = children(p, &mut nodes, 0)? else {
        return Ok(None);
    };
    if nodes.len() as u32 - 1 != root {
        return Err(p.error("internal: the root of an sdf tree is not its last node"));
    }
    Ok(Some(SdfTree { nodes }))
}

/// The nested `<sdf>` elements of `p`, united; `None` when there are none.
fn children(
    p: &mut dyn Params,
    nodes: &mut Vec<Node>,
    depth: usize,
) -> Result<Option<u32>, ParamError> {
    let mut all = Vec::new();
    let mut i = 0;
    while let Some((_, mut c)) = p.nth_child(Family::Sdf, i)? {
        all.push(node_from_params(c.as_mut(), nodes, depth + 1)?);
        i += 1;
    }
    Ok(fold(Op::Union, &all, nodes))
}

/// `ids` combined left to right by `op`.
fn fold(op: Op, ids: &[u32], nodes: &mut Vec<Node>) -> Option<u32> {
    let (&first, rest) = ids.split_first()?;
    Some(
        rest.iter()
            .fold(first, |a, &b| push(nodes, Node::Combine { op, a, b })),
    )
}

fn push(nodes: &mut Vec<Node>, node: Node) -> u32 {
    nodes.push(node);
    nodes.len() as u32 - 1
}

/// Every node type `<sdf type=...>` can name.
pub const NODE_TYPES: &str = "sphere, box, round_box, torus, cylinder, capsule, plane, \
     hex_prism, mandelbox, union, intersection, difference, smooth_union, \
     smooth_intersection, smooth_difference, repeat, round, onion";

fn node_from_params(
    p: &mut dyn Params,
    nodes: &mut Vec<Node>,
    depth: usize,
) -> Result<u32, ParamError> {
    if depth > MAX_DEPTH {
        return Err(p.error(&format!("sdf nodes nest deeper than {MAX_DEPTH} levels")));
    }
    let to_world = p.transform_or_identity("to_world")?;
    let kind = p.plugin_type();
    let node = match kind.as_str() {
        "union"
        | "intersection"
        | "difference"
        | "smooth_union"
        | "smooth_intersection"
        | "smooth_difference" => return operation(p, &kind, nodes, depth, to_world),
        "repeat" | "round" | "onion" => return modifier(p, &kind, nodes, depth, to_world),
        "sphere" => Node::Sphere {
            center: p.point("center")?.unwrap_or(Vec3::ZERO),
            radius: p.positive_float_or("radius", 1.0)?,
        },
        "box" => Node::Box {
            center: p.point("center")?.unwrap_or(Vec3::ZERO),
            half: positive_vector(p, "half_size", Vec3::ONE)?,
        },
        "round_box" => {
            let half = positive_vector(p, "half_size", Vec3::ONE)?;
            let radius = p.positive_float_or("radius", 0.1)?;
            if radius > half.min_element() {
                return Err(p.param_error("radius", "is larger than the box's half size"));
            }
            Node::RoundBox { half, radius }
        }
        "torus" => Node::Torus {
            major: p.positive_float_or("major_radius", 1.0)?,
            minor: p.positive_float_or("minor_radius", 0.25)?,
        },
        "cylinder" | "capsule" => {
            let a = finite_point(p, "p0", Vec3::ZERO)?;
            let b = finite_point(p, "p1", Vec3::Z)?;
            if a == b {
                return Err(p.error("p0 and p1 must differ"));
            }
            let default = if kind == "cylinder" { 1.0 } else { 0.5 };
            let radius = p.positive_float_or("radius", default)?;
            if kind == "cylinder" {
                Node::Cylinder { a, b, radius }
            } else {
                Node::Capsule { a, b, radius }
            }
        }
        "plane" => {
            let normal = p.vector("normal")?.unwrap_or(Vec3::Z);
            if !(normal.is_finite() && normal.length() > 0.0) {
                return Err(p.param_error("normal", "must be a non-zero vector"));
            }
            Node::Plane {
                normal: normal.normalize(),
                offset: finite_float(p, "offset", 0.0)?,
            }
        }
        "hex_prism" => Node::HexPrism {
            radius: p.positive_float_or("radius", 1.0)?,
            half_height: p.positive_float_or("half_height", 0.5)?,
        },
        "mandelbox" => Node::Mandelbox(Mandelbox::from_params(p)?),
        other => {
            return Err(p.error(&format!(
                "unknown sdf type \"{other}\" (known: {NODE_TYPES})"
            )))
        }
    };
    if p.nth_child(Family::Sdf, 0)?.is_some() {
        return Err(p.error(&format!("an sdf \"{kind}\" holds no nested sdf")));
    }
    let id = push(nodes, node);
    Ok(placed(id, to_world, nodes))
}

/// `child` placed by `to_world` (itself when that is the identity).
fn placed(child: u32, to_world: Transform, nodes: &mut Vec<Node>) -> u32 {
    if to_world == Transform::IDENTITY {
        return child;
    }
    push(
        nodes,
        Node::Placed {
            child,
            to_world: to_world.m,
            to_local: to_world.inv,
            scale: min_singular_value(&to_world.m),
        },
    )
}

fn operation(
    p: &mut dyn Params,
    kind: &str,
    nodes: &mut Vec<Node>,
    depth: usize,
    to_world: Transform,
) -> Result<u32, ParamError> {
    let op = match kind {
        "union" => Op::Union,
        "intersection" => Op::Intersection,
        "difference" => Op::Difference,
        _ => {
            let k = p.positive_float_or("k", 0.1)?;
            match kind {
                "smooth_union" => Op::SmoothUnion(k),
                "smooth_intersection" => Op::SmoothIntersection(k),
                _ => Op::SmoothDifference(k),
            }
        }
    };
    let mut ids = Vec::new();
    let mut i = 0;
    while let Some((_, mut c)) = p.nth_child(Family::Sdf, i)? {
        ids.push(node_from_params(c.as_mut(), nodes, depth + 1)?);
        check_size(c.as_ref(), nodes)?;
        i += 1;
    }
    if ids.len() < 2 {
        return Err(p.error(&format!(
            "an sdf \"{kind}\" needs at least two nested sdf elements, not {}",
            ids.len()
        )));
    }
    let id = match op {
        // a − b − c = a − (b ∪ c), so that a smooth difference blends
        // once with the union of what it cuts away.
        Op::Difference | Op::SmoothDifference(_) => {
            let cut = fold(Op::Union, &ids[1..], nodes).expect("two or more");
            push(
                nodes,
                Node::Combine {
                    op,
                    a: ids[0],
                    b: cut,
                },
            )
        }
        _ => fold(op, &ids, nodes).expect("two or more"),
    };
    Ok(placed(id, to_world, nodes))
}

fn modifier(
    p: &mut dyn Params,
    kind: &str,
    nodes: &mut Vec<Node>,
    depth: usize,
    to_world: Transform,
) -> Result<u32, ParamError> {
    let node = match kind {
        "repeat" => {
            let cell = p
                .vector("cell")?
                .ok_or_else(|| p.error("a repeat needs a \"cell\" vector"))?;
            if !(cell.is_finite() && cell.cmpge(Vec3::ZERO).all() && cell.max_element() > 0.0) {
                return Err(p.param_error(
                    "cell",
                    "must be finite and non-negative with at least one positive side",
                ));
            }
            let limit = p.vector("limit")?;
            if let Some(l) = limit {
                if !(l.is_finite() && l.cmpge(Vec3::ZERO).all() && l.round() == l) {
                    return Err(p.param_error("limit", "must hold whole numbers, 0 or more"));
                }
            }
            let child = single_child(p, kind, nodes, depth)?;
            Node::Repeat { child, cell, limit }
        }
        "round" => {
            let radius = p.positive_float_or("radius", 0.1)?;
            let child = single_child(p, kind, nodes, depth)?;
            Node::Round { child, radius }
        }
        _ => {
            let thickness = p.positive_float_or("thickness", 0.1)?;
            let child = single_child(p, kind, nodes, depth)?;
            Node::Onion { child, thickness }
        }
    };
    let id = push(nodes, node);
    Ok(placed(id, to_world, nodes))
}

fn single_child(
    p: &mut dyn Params,
    kind: &str,
    nodes: &mut Vec<Node>,
    depth: usize,
) -> Result<u32, ParamError> {
    let Some((_, mut c)) = p.nth_child(Family::Sdf, 0)? else {
        return Err(p.error(&format!("an sdf \"{kind}\" needs one nested sdf")));
    };
    let id = node_from_params(c.as_mut(), nodes, depth + 1)?;
    drop(c);
    if p.nth_child(Family::Sdf, 1)?.is_some() {
        return Err(p.error(&format!(
            "an sdf \"{kind}\" takes one nested sdf (wrap several in a union)"
        )));
    }
    check_size(&*p, nodes)?;
    Ok(id)
}

fn check_size(p: &dyn Params, nodes: &[Node]) -> Result<(), ParamError> {
    if nodes.len() > MAX_NODES {
        return Err(p.error(&format!("an sdf tree has more than {MAX_NODES} nodes")));
    }
    Ok(())
}

fn positive_vector(p: &mut dyn Params, name: &str, default: Vec3) -> Result<Vec3, ParamError> {
    let v = p.vector(name)?.unwrap_or(default);
    if !(v.is_finite() && v.cmpgt(Vec3::ZERO).all()) {
        return Err(p.param_error(name, "must be finite and positive on every axis"));
    }
    Ok(v)
}

fn finite_point(p: &mut dyn Params, name: &str, default: Vec3) -> Result<Vec3, ParamError> {
    let v = p.point(name)?.unwrap_or(default);
    if !v.is_finite() {
        return Err(p.param_error(name, "must be finite"));
    }
    Ok(v)
}

fn finite_float(p: &mut dyn Params, name: &str, default: f32) -> Result<f32, ParamError> {
    let v = p.float_or(name, default)?;
    if !v.is_finite() {
        return Err(p.param_error(name, "must be finite"));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_singular_value_of_scales_and_rotations() {
        let m = Affine3A::from_scale(Vec3::new(2.0, 0.5, 3.0));
        assert!((min_singular_value(&m) - 0.5).abs() < 1e-5);
        let r = Affine3A::from_rotation_x(0.7) * Affine3A::from_scale(Vec3::splat(1.5));
        assert!((min_singular_value(&r) - 1.5).abs() < 1e-5);
        let shear = Affine3A::from_cols(
            Vec3::X.into(),
            Vec3::new(1.0, 1.0, 0.0).into(),
            Vec3::Z.into(),
            Vec3::ZERO.into(),
        );
        // [[1,1],[0,1]] has singular values (√5 ∓ 1)/2.
        assert!((min_singular_value(&shear) - (5f32.sqrt() - 1.0) / 2.0).abs() < 1e-5);
    }

    /// Every primitive's distance is a lower bound that is tight: for
    /// random points, no point of the surface (found by bisection along
    /// random directions) is nearer than the distance says, and the
    /// distance is reached within 1 % along the gradient.
    #[test]
    fn primitives_are_exact_distances() {
        let prims = [
            Node::Sphere {
                center: Vec3::new(0.1, 0.0, 0.2),
                radius: 0.8,
            },
            Node::Box {
                center: Vec3::ZERO,
                half: Vec3::new(0.5, 0.7, 0.3),
            },
            Node::RoundBox {
                half: Vec3::new(0.5, 0.7, 0.3),
                radius: 0.1,
            },
            Node::Torus {
                major: 0.7,
                minor: 0.2,
            },
            Node::Cylinder {
                a: Vec3::new(0.0, 0.0, -0.5),
                b: Vec3::new(0.2, 0.1, 0.6),
                radius: 0.4,
            },
            Node::Capsule {
                a: Vec3::new(0.0, 0.0, -0.5),
                b: Vec3::new(0.2, 0.1, 0.6),
                radius: 0.3,
            },
            Node::HexPrism {
                radius: 0.5,
                half_height: 0.4,
            },
        ];
        let mut rng = crate::sampler::Pcg32::new(7, 0);
        for prim in prims {
            let tree = SdfTree::single(prim.clone());
            for _ in 0..300 {
                let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 3.0 - 1.5;
                let d = tree.distance(p);
                let dir = crate::sampling::square_to_uniform_sphere(rng.next_2d());
                // Along any direction, the sign does not change before |d|.
                let inside = d < 0.0;
                for k in 1..=20 {
                    let q = p + dir * d.abs() * (k as f32 / 20.0) * 0.999;
                    assert_eq!(
                        tree.distance(q) < 0.0,
                        inside,
                        "{prim:?} at {p}: distance {d} too long"
                    );
                }
                // And along the gradient, the surface is at |d|.
                let h = 1e-3;
                let g = Vec3::new(
                    tree.distance(p + Vec3::X * h) - tree.distance(p - Vec3::X * h),
                    tree.distance(p + Vec3::Y * h) - tree.distance(p - Vec3::Y * h),
                    tree.distance(p + Vec3::Z * h) - tree.distance(p - Vec3::Z * h),
                );
                if g.length() < 1e-4 || d.abs() < 0.02 {
                    continue;
                }
                let q = p - g.normalize() * d * 1.01;
                assert!(
                    (tree.distance(q) < 0.0) != inside || tree.distance(q).abs() < 0.02 * d.abs(),
                    "{prim:?} at {p}: distance {d} too short"
                );
            }
        }
    }

    #[test]
    fn smooth_min_stays_within_a_quarter_of_k() {
        for (a, b) in [(0.0, 0.0), (0.3, 0.1), (-0.2, 0.5), (1.0, 1.05)] {
            let s = smooth_min(a, b, 0.2);
            assert!(s <= a.min(b) && s >= a.min(b) - 0.05 - 1e-7);
        }
        assert_eq!(smooth_min(0.0, 1.0, 0.2), 0.0);
    }
}
