//! `linearcurve`: polylines of round segments, each the rounded cone
//! between two spheres (Mitsuba 3's `linearcurve`, as Embree's round
//! linear curves make it), in the BVH beside every other shape.
//!
//! | parameter  | type      | default  | meaning |
//! |------------|-----------|----------|---------|
//! | `filename` | string    | —        | a text file of control points `x y z r`, one per line; a blank line ends a curve |
//! | `to_world` | transform | identity | moves the control points (not their radii, as in Mitsuba) |
//!
//! ```xml
//! <shape type="linearcurve">
//!     <string name="filename" value="hair.txt"/>
//!     <bsdf type="diffuse"/>
//! </shape>
//! ```
//!
//! **The file**, as Mitsuba 3.9.1 reads it: four numbers per line (more
//! are ignored), whitespace-separated; a blank line ends a curve; no
//! comments. A curve of n ≥ 2 points has n − 1 segments, and the segments
//! of all curves are one list. A line that is not four numbers, a radius
//! or position that is not finite, a curve of one point and a file
//! without points are errors naming the file and line.
//!
//! **The surface.** A segment from (p₀, r₀) to (p₁, r₁) is the union of
//! the spheres about p₀ + v (p₁ − p₀) of radius r₀ + v (r₁ − r₀), v in
//! [0, 1]: the convex hull of its end spheres (a cone frustum tangent to
//! both, capped by them), so joints are round and ends are capped. It is
//! intersected in closed form (the cone's quadratic, the caps' spheres).
//! Only where a ray enters counts: a ray starting inside a segment
//! passes through it, as Mitsuba culls back faces. The normal points away
//! from the touching sphere's centre. uv: u goes round the fibre
//! (0 towards T̂ × û, ¼ towards û, with û world +z made perpendicular to
//! the segment's direction T̂, or +y for a vertical segment), v is
//! (segment index + the touching sphere's parameter) / segment count over
//! the whole file. Where two segments meet, a hit on the joint's sphere
//! is the end of one and the start of the next at the same distance; the
//! segments' u differ there (their T̂ do), and which one a renderer reports
//! is its BVH's choice (Mitsuba's parity scene differs from yubin's in a
//! few such pixels of sharp bends). The shading frame is built from the normal alone
//! (Mitsuba 3.9.1 computes no ∂p/∂u for linear curves), so it is not tied
//! to the fibre's direction. Curves cannot be area emitters (Mitsuba cannot
//! sample them either).
//!
//! Reference: Mitsuba 3 documentation, "Linear curve (linearcurve)";
//! Embree's round linear curves.

use super::{make_interaction_in_frame, PositionSample, PrimHit, ShapeModel, TriangleMesh};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Frame, Ray};
use crate::params::{ParamError, Params};
use glam::{Vec2, Vec3, Vec4};

/// The control points of a curve file: each curve's points (x, y, z, r).
pub fn parse_curve_file(
    text: &str,
    min_points: usize,
    kind: &str,
) -> Result<Vec<Vec<Vec4>>, String> {
    let mut curves = Vec::new();
    let mut current: Vec<Vec4> = Vec::new();
    let mut end = |current: &mut Vec<Vec4>, line: usize| -> Result<(), String> {
        if current.is_empty() {
            return Ok(());
        }
        if current.len() < min_points {
            return Err(format!(
                "line {line}: a {kind} curve needs at least {min_points} control points, this one has {}",
                current.len()
            ));
        }
        curves.push(std::mem::take(current));
        Ok(())
    };
    let mut last = 0;
    for (i, line) in text.lines().enumerate() {
        let number = i + 1;
        last = number;
        if line.trim().is_empty() {
            end(&mut current, number)?;
            continue;
        }
        let values: Vec<f32> = line
            .split_whitespace()
            .take(4)
            .map(|w| w.parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("line {number}: \"{line}\" is not four numbers x y z r"))?;
        if values.len() < 4 {
            return Err(format!(
                "line {number}: \"{line}\" is not four numbers x y z r"
            ));
        }
        let p = Vec4::new(values[0], values[1], values[2], values[3]);
        if !p.truncate().is_finite() {
            return Err(format!("line {number}: the position is not finite"));
        }
        if !p.w.is_finite() {
            return Err(format!("line {number}: the radius is not finite"));
        }
        current.push(p);
    }
    end(&mut current, last)?;
    if curves.is_empty() {
        return Err("the file holds no control points".into());
    }
    Ok(curves)
}

/// One segment: its end spheres (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Start (x, y, z, radius).
    pub a: Vec4,
    /// End.
    pub b: Vec4,
}

/// The segments of a `linearcurve`.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearCurveData {
    /// Every segment of every curve.
    pub segments: Vec<Segment>,
}

impl LinearCurveData {
    fn interned(self) -> &'static LinearCurveData {
        static INTERNED: std::sync::Mutex<Vec<&'static LinearCurveData>> =
            std::sync::Mutex::new(Vec::new());
        super::interned(&INTERNED, self)
    }
}

/// A `linearcurve` shape.
#[derive(Clone, Copy, Debug)]
pub struct LinearCurve {
    /// Its segments.
    pub data: &'static LinearCurveData,
}

impl LinearCurve {
    /// The shape from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let segments = curve_points(p, 2, "linear")?
            .iter()
            .flat_map(|c| c.windows(2).map(|w| Segment { a: w[0], b: w[1] }))
            .collect();
        Ok(Self {
            data: LinearCurveData { segments }.interned(),
        })
    }
}

/// The curves of a curve shape's file (`filename`, each of at least
/// `min_points` points), placed by its `to_world` (radii unchanged).
pub(super) fn curve_points(
    p: &mut dyn Params,
    min_points: usize,
    kind: &str,
) -> Result<Vec<Vec<Vec4>>, ParamError> {
    let Some(bytes) = p.file_bytes("filename")? else {
        return Err(p.error("needs a \"filename\": a text file of control points"));
    };
    let file = p.string("filename")?.unwrap_or_default();
    let text = String::from_utf8_lossy(&bytes);
    let curves = parse_curve_file(&text, min_points, kind)
        .map_err(|e| p.param_error("filename", &format!("{file}: {e}")))?;
    let to_world = p.transform_or_identity("to_world")?;
    Ok(curves
        .into_iter()
        .map(|c| {
            c.into_iter()
                .map(|q| to_world.point(q.truncate()).extend(q.w))
                .collect()
        })
        .collect())
}

/// Where the unit vector `rho` (from the fibre's axis) points round a
/// fibre of direction `tangent`, in turns from 0 to 1: 0 towards
/// T̂ × û, ¼ towards û, û world +z made perpendicular to T̂ (+y for a
/// vertical fibre), as Mitsuba measures it.
pub(super) fn turn_around(tangent: Vec3, rho: Vec3) -> f32 {
    let up = Vec3::Z - tangent * tangent.z;
    let u_rot = if tangent.z.abs() == 1.0 || up.length_squared() == 0.0 {
        Vec3::Y
    } else {
        up.normalize()
    };
    let u_rad = u_rot.cross(tangent);
    let turn = rho.dot(u_rot).atan2(rho.dot(u_rad)) / std::f32::consts::TAU;
    turn - turn.floor()
}

/// A segment's cone in the plane of its axis: the axis, its length, the
/// cone's half-angle β (sin, cos) and where its lateral surface runs.
struct Cone {
    p0: Vec3,
    axis: Vec3,
    length: f32,
    r0: f32,
    r1: f32,
    sin_b: f32,
    cos_b: f32,
}

impl Cone {
    /// `None` when one end sphere holds the other (the segment is then
    /// that sphere).
    fn of(s: &Segment) -> Option<Cone> {
        let d = s.b.truncate() - s.a.truncate();
        let length = d.length();
        let (r0, r1) = (s.a.w, s.b.w);
        if length <= (r0 - r1).abs() || length == 0.0 {
            return None;
        }
        let sin_b = (r0 - r1) / length;
        Some(Cone {
            p0: s.a.truncate(),
            axis: d / length,
            length,
            r0,
            r1,
            sin_b,
            cos_b: (1.0 - sin_b * sin_b).max(0.0).sqrt(),
        })
    }

    /// Axial coordinates where the lateral surface meets the caps.
    fn lateral_range(&self) -> (f32, f32) {
        (self.r0 * self.sin_b, self.length + self.r1 * self.sin_b)
    }
}

/// Where a ray enters the sphere (c, r), if it does.
#[inline]
fn sphere_entry(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<f32> {
    let a = d.length_squared();
    let t_mid = (c - o).dot(d) / a;
    let closest = o + d * t_mid - c;
    let h2 = (r * r - closest.length_squared()) / a;
    (h2 >= 0.0).then(|| t_mid - h2.sqrt())
}

/// Where the ray `o + t d` enters the segment, and the touching sphere's
/// parameter there.
pub(super) fn enter(s: &Segment, o: Vec3, d: Vec3) -> Option<(f32, f32)> {
    let Some(cone) = Cone::of(s) else {
        let (c, r, v) = if s.a.w >= s.b.w {
            (s.a.truncate(), s.a.w, 0.0)
        } else {
            (s.b.truncate(), s.b.w, 1.0)
        };
        return sphere_entry(o, d, c, r).map(|t| (t, v));
    };
    let (z0, z1) = cone.lateral_range();
    let axial = |t: f32| (o + d * t - cone.p0).dot(cone.axis);
    let mut best: Option<(f32, f32)> = None;
    let mut offer = |t: f32, v: f32| {
        if best.is_none_or(|(b, _)| t < b) {
            best = Some((t, v));
        }
    };
    // The caps: where each end sphere's entry lies beyond the lateral part.
    if let Some(t) = sphere_entry(o, d, cone.p0, cone.r0) {
        if axial(t) <= z0 {
            offer(t, 0.0);
        }
    }
    if let Some(t) = sphere_entry(o, d, s.b.truncate(), cone.r1) {
        if axial(t) >= z1 {
            offer(t, 1.0);
        }
    }
    // The lateral surface: q cos β = r₀ − z sin β, q the distance from the
    // axis, z the axial coordinate (both linear or quadratic along the ray).
    let (oz, dz) = ((o - cone.p0).dot(cone.axis), d.dot(cone.axis));
    let (ow, dw) = (o - cone.p0 - cone.axis * oz, d - cone.axis * dz);
    let c2 = cone.cos_b * cone.cos_b;
    let qa = c2 * dw.length_squared() - (cone.sin_b * dz).powi(2);
    let qb = 2.0 * (c2 * ow.dot(dw) + cone.sin_b * dz * (cone.r0 - cone.sin_b * oz));
    let qc = c2 * ow.length_squared() - (cone.r0 - cone.sin_b * oz).powi(2);
    for t in quadratic_roots(qa, qb, qc).into_iter().flatten() {
        let z = oz + dz * t;
        if !(z0..=z1).contains(&z) || cone.r0 - z * cone.sin_b < 0.0 {
            continue;
        }
        let radial = (ow + dw * t).normalize_or_zero();
        let n = radial * cone.cos_b + cone.axis * cone.sin_b;
        if n.dot(d) < 0.0 {
            let v = (z - cone.r0 * cone.sin_b) / (cone.length * cone.cos_b * cone.cos_b);
            offer(t, v.clamp(0.0, 1.0));
        }
    }
    best
}

/// The real roots of a t² + b t + c = 0 (a linear equation when a = 0).
#[inline]
fn quadratic_roots(a: f32, b: f32, c: f32) -> [Option<f32>; 2] {
    if a.abs() < 1e-12 * (b.abs() + c.abs()).max(1e-30) {
        return [(b != 0.0).then(|| -c / b), None];
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return [None, None];
    }
    // The stable form: no cancellation in either root.
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    [Some(q / a), (q != 0.0).then(|| c / q)]
}

impl ShapeModel for LinearCurve {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        self.data.segments.len() as u32
    }

    fn prim_bounds(&self, _: &[TriangleMesh], prim: u32) -> Bounds3 {
        let s = &self.data.segments[prim as usize];
        let sphere = |q: Vec4| Bounds3 {
            min: q.truncate() - Vec3::splat(q.w.abs()),
            max: q.truncate() + Vec3::splat(q.w.abs()),
        };
        sphere(s.a).union(sphere(s.b))
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], prim: u32, ray: &Ray) -> Option<PrimHit> {
        let (t, v) = enter(&self.data.segments[prim as usize], ray.o, ray.d)?;
        (t > ray.t_min && t <= ray.t_max).then_some(PrimHit {
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
        let s = &self.data.segments[prim as usize];
        let v = hit.uv.x;
        let p = ray.at(hit.t);
        let centre = s.a.truncate().lerp(s.b.truncate(), v);
        let n = (p - centre).try_normalize().unwrap_or(-ray.d);
        let tangent = (s.b.truncate() - s.a.truncate()).normalize_or_zero();
        let uv = Vec2::new(
            turn_around(tangent, n),
            (prim as f32 + v) / self.data.segments.len() as f32,
        );
        let frame = Frame::from_normal(n);
        make_interaction_in_frame(ray, hit.t, p, frame, uv, frame.s, frame.t)
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

    fn segment(a: [f32; 4], b: [f32; 4]) -> Segment {
        Segment {
            a: Vec4::from(a),
            b: Vec4::from(b),
        }
    }

    /// Every entering hit lies on the envelope of the swept spheres
    /// (|p − c(v)| = r(v), no sphere of the segment reaching past it), for
    /// rays from all around a tapered segment; rays from inside see
    /// nothing.
    #[test]
    fn hits_lie_on_the_swept_spheres_envelope() {
        let s = segment([0.0, 0.0, 0.0, 0.5], [0.3, 0.2, 3.0, 0.2]);
        let distance = |p: Vec3| {
            (0..=2000)
                .map(|i| {
                    let v = i as f32 / 2000.0;
                    let c = s.a.truncate().lerp(s.b.truncate(), v);
                    (p - c).length() - (s.a.w + (s.b.w - s.a.w) * v)
                })
                .fold(f32::INFINITY, f32::min)
        };
        let mut rng = crate::sampler::Pcg32::new(3, 5);
        let mut hits = 0;
        for _ in 0..2000 {
            let dir = crate::sampling::square_to_uniform_sphere(rng.next_2d());
            let target = Vec3::new(0.15, 0.1, 1.5)
                + (crate::sampling::square_to_uniform_sphere(rng.next_2d()) * 0.6);
            let o = target - dir * 6.0;
            if let Some((t, v)) = enter(&s, o, dir) {
                hits += 1;
                let p = o + dir * t;
                assert!(distance(p).abs() < 2e-3, "{p}: {}", distance(p));
                let c = s.a.truncate().lerp(s.b.truncate(), v);
                let r = s.a.w + (s.b.w - s.a.w) * v;
                assert!(((p - c).length() - r).abs() < 2e-3, "v {v}");
            } else {
                // A miss: the ray stays outside (sampled along it).
                for k in 0..200 {
                    assert!(distance(o + dir * (k as f32 * 0.06)) > -1e-3);
                }
            }
        }
        assert!(hits > 500, "{hits}");
        // From inside, along and across the axis: nothing.
        for d in [Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.2).normalize()] {
            assert!(enter(&s, Vec3::new(0.1, 0.05, 1.0), d).is_none_or(|(t, _)| t < 0.0));
        }
    }

    #[test]
    fn curve_files_are_parsed_and_checked() {
        let c = parse_curve_file(
            "0 0 0 0.1\n1 0 0 0.1 extra\n\n\n0 1 0 .2\n0 2 0 0.2\n0 3 0 0.2",
            2,
            "linear",
        )
        .unwrap();
        assert_eq!(c.iter().map(Vec::len).collect::<Vec<_>>(), [2, 3]);
        let e = |t: &str| parse_curve_file(t, 2, "linear").unwrap_err();
        assert!(e("0 0 0 0.1\n1 0 0\n").contains("line 2"));
        assert!(e("0 0 0 0.1\n1 abc 0 0.1\n").contains("not four numbers"));
        assert!(e("0 0 0 0.1\n\n1 0 0 0.1\n2 0 0 0.1").contains("at least 2"));
        assert!(e("\n\n").contains("no control points"));
        assert!(e("0 0 0 0.1\n1 0 inf 0.1").contains("position is not finite"));
        assert!(e("# comment\n").contains("line 1"));
    }
}
