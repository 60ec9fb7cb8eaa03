//! `bsplinecurve`: smooth tubes along uniform cubic B-splines (Mitsuba 3's
//! `bsplinecurve`, as Embree's round B-spline curves make it), for hair
//! and fur, in the BVH beside every other shape.
//!
//! | parameter  | type      | default  | meaning |
//! |------------|-----------|----------|---------|
//! | `filename` | string    | —        | a text file of control points `x y z r`, one per line; a blank line ends a curve (as `linearcurve`'s) |
//! | `to_world` | transform | identity | moves the control points (not their radii, as in Mitsuba) |
//!
//! ```xml
//! <shape type="bsplinecurve">
//!     <string name="filename" value="hair.txt"/>
//!     <bsdf type="hair"/>
//! </shape>
//! ```
//!
//! A curve of n ≥ 4 control points has n − 3 segments; segment k's centre
//! c(v) and radius r(v), v in [0, 1], blend points k … k + 3 by the uniform
//! cubic B-spline basis ((1−v)³, 3v³ − 6v² + 4, −3v³ + 3v² + 3v + 1,
//! v³)/6, so the curve does not pass through its end points. The surface
//! is the tube of circles of radius r(v) about c(v) perpendicular to the
//! tangent c′(v) (what Embree intersects, measured through Mitsuba 3.9.1:
//! its hits satisfy |p − c(v)| = r(v) and (p − c(v))·c′(v) = 0). Its ends
//! are open. Only where a ray enters counts, as Mitsuba culls back faces.
//!
//! **Intersection.** Each segment is split into 4 pieces, each bounded by
//! the rounded cone between its end circles widened by the piece's
//! departure from it (computed once, as the file loads) and each a
//! primitive of the BVH, boxed by its cone (a ray that reaches one first
//! tests the sphere around it); where the ray enters one, Newton's method on
//! (t, v) solves (o + t d − c(v))·c′(v) = 0, |o + t d − c(v)|² = r(v)², and
//! the nearest converged solution with v in [0, 1] where the ray enters
//! (d·n < 0) is the hit. The normal is the tube's:
//! n ∝ (|c′|² − ρ·c″) ρ − r r′ c′, ρ = p − c(v).
//!
//! uv and frame as Mitsuba's: u goes round the fibre (0 towards T̂ × û, ¼
//! towards û, û world +z made perpendicular to the tangent T̂, or +y), v is
//! (segment index + v) / segment count over the file; ∂p/∂u = 2π r T̂ × ρ̂,
//! so the shading frame's s runs round the fibre, t along it and n out
//! (the frame `hair` reads). Curves cannot be area emitters.
//!
//! Reference: Mitsuba 3 documentation, "B-spline curve (bsplinecurve)";
//! Embree's round B-spline curves.

use super::linearcurve::{curve_points, enter, turn_around, Segment};
use super::{make_interaction_in_frame, PositionSample, PrimHit, ShapeModel, TriangleMesh};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Frame, Ray};
use crate::params::{ParamError, Params};
use glam::{Vec2, Vec3, Vec4};

/// Pieces each segment is bounded by.
const PIECES: usize = 4;

/// The segments of a `bsplinecurve`: four control points each.
#[derive(Clone, Debug, PartialEq)]
pub struct BSplineData {
    /// Every segment of every curve.
    pub segments: Vec<[Vec4; 4]>,
    /// Each segment's bounding rounded cones (see [`piece_hulls`]).
    pub hulls: Vec<[Segment; PIECES]>,
}

impl BSplineData {
    fn interned(self) -> &'static BSplineData {
        static INTERNED: std::sync::Mutex<Vec<&'static BSplineData>> =
            std::sync::Mutex::new(Vec::new());
        super::interned(&INTERNED, self)
    }
}

/// A `bsplinecurve` shape.
#[derive(Clone, Copy, Debug)]
pub struct BSplineCurve {
    /// Its segments.
    pub data: &'static BSplineData,
}

impl BSplineCurve {
    /// The shape from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let segments: Vec<[Vec4; 4]> = curve_points(p, 4, "B-spline")?
            .iter()
            .flat_map(|c| c.windows(4).map(|w| [w[0], w[1], w[2], w[3]]))
            .collect();
        let hulls = segments.iter().map(piece_hulls).collect();
        Ok(Self {
            data: BSplineData { segments, hulls }.interned(),
        })
    }
}

/// The centre and radius, and their first and second derivatives, of
/// segment `q` at `v`.
#[inline]
fn evaluate(q: &[Vec4; 4], v: f32) -> (Vec4, Vec4, Vec4) {
    let w = 1.0 - v;
    let b = [
        w * w * w / 6.0,
        (3.0 * v * v * v - 6.0 * v * v + 4.0) / 6.0,
        (-3.0 * v * v * v + 3.0 * v * v + 3.0 * v + 1.0) / 6.0,
        v * v * v / 6.0,
    ];
    let db = [
        -0.5 * w * w,
        0.5 * (3.0 * v * v - 4.0 * v),
        0.5 * (-3.0 * v * v + 2.0 * v + 1.0),
        0.5 * v * v,
    ];
    let ddb = [w, 3.0 * v - 2.0, 1.0 - 3.0 * v, v];
    let mix = |k: [f32; 4]| q[0] * k[0] + q[1] * k[1] + q[2] * k[2] + q[3] * k[3];
    (mix(b), mix(db), mix(ddb))
}

/// The tube's outward normal (unnormalized) at `p` for the circle at `v`.
#[inline]
fn tube_normal(q: &[Vec4; 4], v: f32, p: Vec3) -> Vec3 {
    let (c, dc, ddc) = evaluate(q, v);
    let rho = p - c.truncate();
    let d1 = dc.truncate();
    (d1.length_squared() - rho.dot(ddc.truncate())) * rho - c.w * dc.w * d1
}

/// Newton's method on (t, v) from (t, v): the ray's crossing of the tube
/// near there, if it converges (the residuals checked in the end, to the
/// precision single floats allow at the ray's distance).
fn refine(
    q: &[Vec4; 4],
    o: Vec3,
    d: Vec3,
    mut t: f32,
    mut v: f32,
    range: (f32, f32),
) -> Option<(f32, f32)> {
    for _ in 0..12 {
        let (c, dc, ddc) = evaluate(q, v);
        let rho = o + d * t - c.truncate();
        let d1 = dc.truncate();
        let g1 = rho.dot(d1);
        let g2 = rho.length_squared() - c.w * c.w;
        let (a11, a12) = (d.dot(d1), rho.dot(ddc.truncate()) - d1.length_squared());
        let (a21, a22) = (2.0 * rho.dot(d), -2.0 * g1 - 2.0 * c.w * dc.w);
        let det = a11 * a22 - a12 * a21;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let dt = (g1 * a22 - g2 * a12) / det;
        let dv = (a11 * g2 - a21 * g1) / det;
        t -= dt;
        v -= dv.clamp(-0.25, 0.25);
        if !(range.0..=range.1).contains(&v) {
            return None;
        }
        if dt.abs() <= 1e-6 * t.abs().max(1.0) && dv.abs() <= 1e-5 {
            break;
        }
    }
    let (c, dc, _) = evaluate(q, v);
    let rho = o + d * t - c.truncate();
    let tolerance = 1e-4 * c.w.abs() + 1e-6 * (t.abs() + (o - c.truncate()).length());
    let on_circle = (rho.length() - c.w.abs()).abs() <= tolerance;
    let perpendicular = rho.dot(dc.truncate().normalize_or_zero()).abs() <= tolerance;
    (on_circle && perpendicular && t.is_finite()).then_some((t, v))
}

/// Whether the ray's line passes outside the sphere around `hull` (a cheap
/// test before the rounded cone's).
#[inline]
fn misses_bounding_sphere(hull: &Segment, o: Vec3, d: Vec3) -> bool {
    let (a, b) = (hull.a.truncate(), hull.b.truncate());
    let centre = (a + b) * 0.5;
    let radius = 0.5 * (b - a).length() + hull.a.w.max(hull.b.w);
    (centre - o).cross(d).length_squared() > radius * radius * d.length_squared()
}

/// The rounded cones bounding segment `q`'s pieces: between the circles
/// at their ends, widened by the most the piece departs from that cone
/// (its centre from the chord plus its radius above the chord's, at 9
/// points along it) and 5 % of its radius.
fn piece_hulls(q: &[Vec4; 4]) -> [Segment; PIECES] {
    std::array::from_fn(|k| {
        let (va, vb) = (k as f32 / PIECES as f32, (k + 1) as f32 / PIECES as f32);
        let (start, end) = (evaluate(q, va).0, evaluate(q, vb).0);
        let departure = (1..10)
            .map(|i| {
                let s = i as f32 / 10.0;
                let on_curve = evaluate(q, va + (vb - va) * s).0;
                let on_chord = start.lerp(end, s);
                (on_curve - on_chord).truncate().length() + (on_curve.w.abs() - on_chord.w.abs())
            })
            .fold(0.0f32, f32::max);
        let grow = departure + 0.05 * start.w.abs().max(end.w.abs());
        Segment {
            a: start.truncate().extend(start.w.abs() + grow),
            b: end.truncate().extend(end.w.abs() + grow),
        }
    })
}

/// Where the ray `o + t d` enters segment `q` from piece `k` of it
/// (bounded by `hull`), and v there.
#[inline]
fn enter_piece(
    q: &[Vec4; 4],
    hull: &Segment,
    k: usize,
    o: Vec3,
    d: Vec3,
    t_min: f32,
) -> Option<(f32, f32)> {
    if misses_bounding_sphere(hull, o, d) {
        return None;
    }
    let (t0, v_local) = enter(hull, o, d)?;
    let va = k as f32 / PIECES as f32;
    // A solution beyond the neighbouring pieces is theirs to find.
    let width = 1.0 / PIECES as f32;
    let range = (va - width, va + 2.0 * width);
    let (t, v) = refine(q, o, d, t0, va + v_local * width, range)?;
    let entering =
        (0.0..=1.0).contains(&v) && t > t_min && tube_normal(q, v, o + d * t).dot(d) < 0.0;
    entering.then_some((t, v))
}

/// Where the ray `o + t d` enters segment `q` (bounded by `hulls`), and v
/// there: the nearest of its pieces' entries.
#[cfg(test)]
fn enter_segment(
    q: &[Vec4; 4],
    hulls: &[Segment; PIECES],
    o: Vec3,
    d: Vec3,
    t_min: f32,
) -> Option<(f32, f32)> {
    (hulls.iter().enumerate())
        .filter_map(|(k, hull)| enter_piece(q, hull, k, o, d, t_min))
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

impl ShapeModel for BSplineCurve {
    // Each piece of each segment is a primitive of its own, bounded by its
    // rounded cone: the BVH then leaves out the pieces a ray passes by.
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        (self.data.segments.len() * PIECES) as u32
    }

    fn prim_bounds(&self, _: &[TriangleMesh], prim: u32) -> Bounds3 {
        let (i, k) = (prim as usize / PIECES, prim as usize % PIECES);
        let hull = &self.data.hulls[i][k];
        [hull.a, hull.b].iter().fold(Bounds3::EMPTY, |b, p| {
            let r = Vec3::splat(p.w.abs());
            b.union_point(p.truncate() - r)
                .union_point(p.truncate() + r)
        })
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], prim: u32, ray: &Ray) -> Option<PrimHit> {
        let (i, k) = (prim as usize / PIECES, prim as usize % PIECES);
        let (t, v) = enter_piece(
            &self.data.segments[i],
            &self.data.hulls[i][k],
            k,
            ray.o,
            ray.d,
            ray.t_min,
        )?;
        (t <= ray.t_max).then_some(PrimHit {
            t,
            uv: Vec2::new(v, 0.0),
        })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let segment = prim as usize / PIECES;
        let q = &self.data.segments[segment];
        let v = hit.uv.x;
        let p = ray.at(hit.t);
        let (c, dc, _) = evaluate(q, v);
        let n = tube_normal(q, v, p).try_normalize().unwrap_or(-ray.d);
        let tangent = dc.truncate().normalize_or_zero();
        let rho = (p - c.truncate()).normalize_or_zero();
        let segments = self.data.segments.len() as f32;
        let uv = Vec2::new(turn_around(tangent, rho), (segment as f32 + v) / segments);
        let dpdu = tangent.cross(rho) * (std::f32::consts::TAU * c.w);
        let dpdv = dc.truncate() * segments;
        let frame = Frame::from_normal_and_tangent(n, dpdu);
        make_interaction_in_frame(ray, hit.t, p, frame, uv, dpdu, dpdv)
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

    /// Hits lie on the tube (|p − c(v)| = r(v), p − c(v) ⟂ c′(v)), rays
    /// from inside see nothing, and the ends are open.
    #[test]
    fn hits_lie_on_the_tube_of_perpendicular_circles() {
        let q = [
            Vec4::new(0.0, 0.0, -3.0, 0.1),
            Vec4::new(0.3, 0.5, -1.0, 0.3),
            Vec4::new(-0.2, 0.4, 1.0, 0.5),
            Vec4::new(0.5, -0.2, 3.0, 0.2),
        ];
        let hulls = piece_hulls(&q);
        let mut rng = crate::sampler::Pcg32::new(9, 2);
        let mut hits = 0;
        for _ in 0..3000 {
            let dir = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            let v = rng.next_f32();
            let aim = evaluate(&q, v).0.truncate()
                + crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 0.5;
            let o = aim - dir * 5.0;
            if let Some((t, v)) = enter_segment(&q, &hulls, o, dir, 0.0) {
                hits += 1;
                let p = o + dir * t;
                let (c, dc, _) = evaluate(&q, v);
                let rho = p - c.truncate();
                assert!(
                    (rho.length() - c.w).abs() < 1e-3,
                    "radius {} vs {}",
                    rho.length(),
                    c.w
                );
                assert!(
                    rho.dot(dc.truncate()).abs() < 1e-3 * dc.truncate().length(),
                    "not perpendicular"
                );
            }
        }
        assert!(hits > 1000, "{hits}");
        let inside = evaluate(&q, 0.5).0.truncate();
        for d in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::NEG_Z] {
            assert!(enter_segment(&q, &hulls, inside, d, 0.0).is_none());
        }
        // The curve starts at (P0 + 4 P1 + P2)/6: nothing beyond it.
        let start = evaluate(&q, 0.0).0.truncate();
        assert!(enter_segment(
            &q,
            &hulls,
            start + Vec3::new(5.0, 0.0, -0.3),
            Vec3::NEG_X,
            0.0
        )
        .is_none());
    }
}
