//! `ellipsoids`: Gaussian-splat primitives read from a PLY file, each an
//! exact ellipsoid (Mitsuba 3's `ellipsoids`), in the BVH beside every
//! other shape.
//!
//! | parameter      | type      | default  | meaning |
//! |----------------|-----------|----------|---------|
//! | `filename`     | string    | —        | a PLY file of Gaussians (layout below) |
//! | `extent`       | float     | 3        | the surface lies at `extent` standard deviations: semi-axes `extent` × scale |
//! | `extent_adaptive_clamping` | boolean | false | per Gaussian, extent √(2 ln(opacity / 0.01)) × `extent` / 3 (needs the 3DGS `opacity`) |
//! | `scale_factor` | float     | 1        | multiplies every scale |
//! | `to_world`     | transform | identity | applied to the Gaussians as they load (below) |
//!
//! ```xml
//! <shape type="ellipsoids">
//!     <string name="filename" value="splats.ply"/>
//!     <bsdf type="diffuse"/>
//! </shape>
//! ```
//!
//! **The file**, as Mitsuba 3.9.1 reads it: the first element of the PLY
//! (ASCII or binary), every property a `float`; the first six properties
//! are `x y z nx ny nz` (the normal is not used) and the last seven
//! `scale_0 scale_1 scale_2 rot_0 rot_1 rot_2 rot_3`: log-scales (each
//! becomes max(e^s, 10⁻⁶)) and a rotation quaternion w, x, y, z
//! (normalized). Properties between them are the Gaussian's other data;
//! in the layout of 3D Gaussian Splatting files (`f_dc_0` seventh,
//! `opacity` just before `scale_0`) the opacity is the sigmoid of
//! `opacity`, which `extent_adaptive_clamping` reads. A Gaussian whose
//! opacity is at most 0.01 then has no surface (Mitsuba computes NaN).
//!
//! **`to_world`** is baked into the Gaussians as Mitsuba does: centres
//! take the whole transform, orientations its rotation (the polar
//! decomposition of its linear part, A = Q S) and scales the mean of the
//! stretch S's diagonal, so a non-uniform `to_world` moves centres but
//! does not stretch the ellipsoids unevenly.
//!
//! **As a surface** (`path`, `volpath` and the rest), each Gaussian is the
//! ellipsoid |diag(1/a) Rᵀ (x − c)| = 1, a = extent × scale, with the
//! shape's BSDF; opacity and spherical harmonics do not enter (they are
//! for Mitsuba's Python-side volumetric primitive integrators). Rays see
//! only the outside: a hit counts where the ray enters, so a ray starting
//! inside (a refracted ray, a shadow ray) passes through without a hit,
//! as in Mitsuba (a `dielectric` Gaussian is therefore not a glass ball).
//! The normal is the ellipsoid's gradient; the hit has uv (0, 0). An area
//! emitter cannot be placed on it (Mitsuba cannot sample one either).
//! Mitsuba's `data`, `centers`, `scales` and `quaternions` tensors come
//! from Python dictionaries and have no XML form.
//!
//! References: Mitsuba 3 documentation, "Ellipsoids (ellipsoids)";
//! Kerbl et al. 2023, "3D Gaussian Splatting for Real-Time Radiance Field
//! Rendering" (the file layout); Moënne-Loccoz et al. 2024, "3D Gaussian
//! Ray Tracing" (the adaptive extent); Higham 1986, "Computing the polar
//! decomposition — with applications".

use super::{make_interaction_in_frame, PositionSample, PrimHit, ShapeModel, TriangleMesh};
use crate::interaction::SurfaceInteraction;
use crate::math::{Bounds3, Frame, Ray};
use crate::params::{ParamError, Params};
use glam::{DMat3, DVec3, Mat3, Vec2, Vec3};

/// A table of float properties: the first element of a PLY file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PropertyTable {
    /// Property names, in the file's order.
    pub names: Vec<String>,
    /// Rows (elements).
    pub rows: usize,
    /// Values, row after row.
    pub values: Vec<f32>,
}

/// One Gaussian's ellipsoid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipsoid {
    /// Its centre.
    pub center: Vec3,
    /// World → the unit sphere about the centre: diag(1/a) Rᵀ.
    pub to_unit: Mat3,
}

impl Ellipsoid {
    /// The unit sphere's space → world (about the centre): R diag(a).
    pub fn from_unit(&self) -> Mat3 {
        self.to_unit.inverse()
    }

    /// `ray` in the unit sphere's space (distances along it unchanged).
    #[inline]
    pub(super) fn ray_to_unit(&self, ray: &Ray) -> (Vec3, Vec3) {
        (self.to_unit * (ray.o - self.center), self.to_unit * ray.d)
    }
}

/// Every ellipsoid of a shape.
#[derive(Clone, Debug, PartialEq)]
pub struct EllipsoidsData {
    /// The ellipsoids.
    pub ellipsoids: Vec<Ellipsoid>,
}

impl EllipsoidsData {
    /// The data stored for the program's life, once per content.
    pub fn interned(self) -> &'static EllipsoidsData {
        static INTERNED: std::sync::Mutex<Vec<&'static EllipsoidsData>> =
            std::sync::Mutex::new(Vec::new());
        super::interned(&INTERNED, self)
    }

    /// The Gaussians of an `ellipsoids` or `ellipsoidsmesh` shape's
    /// parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<&'static EllipsoidsData, ParamError> {
        let Some(table) = p.ply_table("filename")? else {
            return Err(p.error("needs a \"filename\": a PLY file of Gaussians"));
        };
        let file = p.string("filename")?.unwrap_or_default();
        let layout =
            Layout::of(&table).map_err(|e| p.param_error("filename", &format!("{file}: {e}")))?;
        let scale_factor = p.positive_float_or("scale_factor", 1.0)?;
        let extent = p.positive_float_or("extent", 3.0)?;
        let mut adaptive = p.boolean_or("extent_adaptive_clamping", false)?;
        if adaptive && layout.opacity.is_none() {
            p.warn(
                Some("extent_adaptive_clamping"),
                "the Gaussians have no 3DGS opacity: extent_adaptive_clamping is off",
            );
            adaptive = false;
        }
        let placement = Placement::of(p.transform("to_world")?.unwrap_or(glam::DMat4::IDENTITY));
        let width = table.names.len();
        let mut ellipsoids = Vec::with_capacity(table.rows);
        for (row, v) in table.values.chunks_exact(width).enumerate() {
            let gaussian_extent = match (adaptive, layout.opacity) {
                (true, Some(c)) => adaptive_extent(sigmoid(v[c]), extent),
                _ => extent,
            };
            if gaussian_extent <= 0.0 {
                continue;
            }
            let e = placement
                .ellipsoid(v, width, scale_factor * gaussian_extent)
                .ok_or_else(|| {
                    p.param_error(
                        "filename",
                        &format!(
                            "{file}: Gaussian {row} is not finite (or its quaternion is zero): {:?}",
                            v
                        ),
                    )
                })?;
            ellipsoids.push(e);
        }
        Ok(EllipsoidsData { ellipsoids }.interned())
    }
}

/// Where the properties Mitsuba reads sit in the table.
struct Layout {
    /// The column of the 3DGS `opacity`, in that layout.
    opacity: Option<usize>,
}

const FIRST: [&str; 6] = ["x", "y", "z", "nx", "ny", "nz"];
const LAST: [&str; 7] = [
    "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
];

impl Layout {
    fn of(table: &PropertyTable) -> Result<Layout, String> {
        let n = table.names.len();
        let fits = n >= FIRST.len() + LAST.len()
            && table.names[..6].iter().zip(FIRST).all(|(a, b)| a == b)
            && table.names[n - 7..].iter().zip(LAST).all(|(a, b)| a == b);
        if !fits {
            return Err(format!(
                "its properties must begin with {} and end with {} (as Mitsuba's ellipsoids read \
                 them), not {}",
                FIRST.join(" "),
                LAST.join(" "),
                table.names.join(" ")
            ));
        }
        let splats = n > 13 && table.names[6] == "f_dc_0" && table.names[n - 8] == "opacity";
        Ok(Layout {
            opacity: splats.then_some(n - 8),
        })
    }
}

/// The logistic function, clamped as Mitsuba clamps opacities.
fn sigmoid(x: f32) -> f32 {
    (1.0 / (1.0 + (-x).exp())).clamp(1e-8, 1.0 - 1e-8)
}

/// 3D Gaussian Ray Tracing's extent for opacity `opacity`: the distance at
/// which the Gaussian's response falls to 0.01, over Mitsuba's default
/// extent 3 (0 where it never reaches 0.01).
fn adaptive_extent(opacity: f32, extent: f32) -> f32 {
    let k = 2.0 * (opacity / 0.01).ln();
    if k > 0.0 {
        k.sqrt() * extent / 3.0
    } else {
        0.0
    }
}

/// `to_world` split as Mitsuba applies it to Gaussians.
struct Placement {
    /// The whole transform, for centres.
    m: glam::DMat4,
    /// The rotation of its polar decomposition.
    rotation: DMat3,
    /// The mean stretch.
    stretch: f64,
}

impl Placement {
    fn of(m: glam::DMat4) -> Placement {
        let a = DMat3::from_mat4(m);
        let rotation = polar_rotation(a);
        let s = rotation.transpose() * a;
        Placement {
            m,
            rotation,
            stretch: (s.x_axis.x + s.y_axis.y + s.z_axis.z) / 3.0,
        }
    }

    /// The ellipsoid of one row `v` of the table (`width` values), its
    /// scales multiplied by `factor`; `None` if not finite.
    fn ellipsoid(&self, v: &[f32], width: usize, factor: f32) -> Option<Ellipsoid> {
        let d = |i: usize| f64::from(v[i]);
        let center = self.m.transform_point3(DVec3::new(d(0), d(1), d(2)));
        let last = width - 7;
        let scale = DVec3::new(d(last), d(last + 1), d(last + 2))
            .to_array()
            .map(|s| s.exp().max(1e-6) * f64::from(factor) * self.stretch);
        let q = glam::DQuat::from_xyzw(d(last + 4), d(last + 5), d(last + 6), d(last + 3));
        if q.length().is_nan() || q.length() <= 0.0 {
            return None;
        }
        let r = self.rotation * DMat3::from_quat(q.normalize());
        let to_unit = DMat3::from_diagonal(DVec3::from(scale).recip()) * r.transpose();
        let e = Ellipsoid {
            center: center.as_vec3(),
            to_unit: to_unit.as_mat3(),
        };
        (e.center.is_finite() && e.to_unit.is_finite() && to_unit.determinant() != 0.0).then_some(e)
    }
}

/// The rotation Q of the polar decomposition A = Q S (S symmetric, positive
/// semi-definite), by Newton's iteration Q ← (Q + Q⁻ᵀ) / 2 (Higham 1986);
/// a reflection in A stays in Q.
fn polar_rotation(a: DMat3) -> DMat3 {
    if a.determinant().abs() < 1e-300 {
        return DMat3::IDENTITY;
    }
    let mut q = a;
    for _ in 0..100 {
        let next = (q + q.inverse().transpose()) * 0.5;
        let change = (next - q)
            .to_cols_array()
            .iter()
            .map(|x| x.abs())
            .fold(0.0, f64::max);
        q = next;
        if change < 1e-15 {
            break;
        }
    }
    q
}

/// An `ellipsoids` shape.
#[derive(Clone, Copy, Debug)]
pub struct Ellipsoids {
    /// The Gaussians.
    pub data: &'static EllipsoidsData,
}

impl Ellipsoids {
    /// The shape from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        Ok(Self {
            data: EllipsoidsData::from_params(p)?,
        })
    }
}

impl ShapeModel for Ellipsoids {
    fn prim_count(&self, _: &[TriangleMesh]) -> u32 {
        self.data.ellipsoids.len() as u32
    }

    fn prim_bounds(&self, _: &[TriangleMesh], prim: u32) -> Bounds3 {
        let e = &self.data.ellipsoids[prim as usize];
        let m = e.from_unit();
        // The box of the unit sphere mapped by m: its rows' lengths.
        let half = Vec3::new(m.row(0).length(), m.row(1).length(), m.row(2).length());
        Bounds3 {
            min: e.center - half,
            max: e.center + half,
        }
    }

    #[inline]
    fn intersect(&self, _: &[TriangleMesh], prim: u32, ray: &Ray) -> Option<PrimHit> {
        let e = &self.data.ellipsoids[prim as usize];
        let (o, d) = e.ray_to_unit(ray);
        // The entering root, from the ray's point nearest the centre (the
        // difference of two close squares would lose the root's digits).
        let a = d.length_squared();
        let t_near_centre = -o.dot(d) / a;
        let closest = o + d * t_near_centre;
        let r2 = closest.length_squared();
        // (NaN, from a ray parallel to nothing, misses too.)
        if r2.is_nan() || r2 > 1.0 {
            return None;
        }
        let t = t_near_centre - ((1.0 - r2) / a).sqrt();
        (t > ray.t_min && t <= ray.t_max).then_some(PrimHit { t, uv: Vec2::ZERO })
    }

    fn interaction(
        &self,
        _: &[TriangleMesh],
        prim: u32,
        ray: &Ray,
        hit: PrimHit,
    ) -> SurfaceInteraction {
        let e = &self.data.ellipsoids[prim as usize];
        let p = ray.at(hit.t);
        let gradient = e.to_unit.transpose() * (e.to_unit * (p - e.center));
        let n = gradient.try_normalize().unwrap_or(-ray.d);
        let frame = Frame::from_normal(n);
        make_interaction_in_frame(ray, hit.t, p, frame, Vec2::ZERO, frame.s, frame.t)
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

    fn table(rows: &[[f32; 13]]) -> PropertyTable {
        PropertyTable {
            names: FIRST.iter().chain(&LAST).map(|s| s.to_string()).collect(),
            rows: rows.len(),
            values: rows.concat(),
        }
    }

    /// A Gaussian at `c` with linear scales `s` and quaternion (w, x, y, z).
    fn row(c: [f32; 3], s: [f32; 3], q: [f32; 4]) -> [f32; 13] {
        [
            c[0],
            c[1],
            c[2],
            0.0,
            0.0,
            0.0,
            s[0].ln(),
            s[1].ln(),
            s[2].ln(),
            q[0],
            q[1],
            q[2],
            q[3],
        ]
    }

    fn shape(rows: &[[f32; 13]], to_world: glam::DMat4) -> Ellipsoids {
        let t = table(rows);
        let placement = Placement::of(to_world);
        let ellipsoids = t
            .values
            .chunks_exact(13)
            .map(|v| placement.ellipsoid(v, 13, 3.0).unwrap())
            .collect();
        Ellipsoids {
            data: EllipsoidsData { ellipsoids }.interned(),
        }
    }

    fn hit(s: &Ellipsoids, o: Vec3, d: Vec3) -> Option<(f32, Vec3)> {
        let ray = Ray::new(o, d.normalize());
        (0..s.prim_count(&[]))
            .filter_map(|i| s.intersect(&[], i, &ray).map(|h| (i, h)))
            .min_by(|a, b| a.1.t.total_cmp(&b.1.t))
            .map(|(i, h)| (h.t, s.interaction(&[], i, &ray, h).n))
    }

    /// Hits as Mitsuba 3.9.1 reports them for three Gaussians (values read
    /// from its `scalar_rgb` variant): distances and gradient normals;
    /// rays from inside see nothing.
    #[test]
    fn hits_match_mitsuba() {
        let half = |deg: f32| (deg.to_radians() / 2.0).sin_cos();
        let (s30, c30) = half(30.0);
        let (s60, c60) = half(60.0);
        let r = std::f32::consts::FRAC_1_SQRT_2;
        let s = shape(
            &[
                row([0.0; 3], [0.2, 0.3, 0.4], [1.0, 0.0, 0.0, 0.0]),
                // Stored twice as long: normalized as it loads.
                row(
                    [1.5, 0.2, -0.3],
                    [0.1, 0.25, 0.15],
                    [2.0 * c30, 0.0, 0.0, 2.0 * s30],
                ),
                row(
                    [-1.2, -0.4, 0.5],
                    [0.3, 0.1, 0.2],
                    [c60, r * s60, r * s60, 0.0],
                ),
            ],
            glam::DMat4::IDENTITY,
        );
        let cases = [
            ([0.0, 0.0, 5.0], [0.0, 0.0, -1.0], 3.8, [0.0, 0.0, 1.0]),
            (
                [0.1, 0.2, 5.0],
                [0.0, 0.0, -1.0],
                3.847226,
                [0.31473, 0.27976, 0.90702],
            ),
            (
                [5.0, 0.2, -0.3],
                [-1.0, 0.0, 0.0],
                3.162482,
                [0.90835, 0.41822, 0.0],
            ),
            (
                [-1.2, -0.4, 5.0],
                [0.0, 0.0, -1.0],
                4.066607,
                [0.28410, 0.58172, 0.76216],
            ),
            (
                [3.0, 3.0, 3.0],
                [-1.0, -1.0, -1.0],
                4.397793,
                [0.89086, 0.39594, 0.22271],
            ),
        ];
        for (o, d, t, n) in cases {
            let (got_t, got_n) = hit(&s, Vec3::from(o), Vec3::from(d)).expect("a hit");
            assert!((got_t - t).abs() < 1e-4 * t, "{o:?}: t {got_t} vs {t}");
            assert!(
                (got_n - Vec3::from(n)).length() < 1e-4,
                "{o:?}: n {got_n} vs {n:?}"
            );
        }
        assert!(hit(&s, Vec3::ZERO, Vec3::Z).is_none());
        assert!(hit(&s, Vec3::new(-1.2, -0.4, 0.5), Vec3::Z).is_none());
        for i in 0..3 {
            let b = s.prim_bounds(&[], i);
            assert!(b.min.cmplt(b.max).all());
        }
    }

    /// `to_world` as Mitsuba bakes it: a uniform scale scales the axes, a
    /// non-uniform one only moves the centre (axes by the mean stretch).
    #[test]
    fn to_world_scales_by_the_mean_stretch() {
        let unit = [row([0.0, 0.0, 1.0], [1.0 / 3.0; 3], [1.0, 0.0, 0.0, 0.0])];
        let m = glam::DMat4::from_scale(DVec3::new(1.0, 2.0, 3.0));
        let s = shape(&unit, m);
        let e = s.data.ellipsoids[0];
        assert!((e.center - Vec3::new(0.0, 0.0, 3.0)).length() < 1e-6);
        // Axes 1 × (1 + 2 + 3) / 3 = 2 in every direction.
        let axes = e.from_unit();
        assert!((axes - Mat3::from_diagonal(Vec3::splat(2.0))).abs_diff_eq(Mat3::ZERO, 1e-5));
        let rotated =
            glam::DMat4::from_rotation_x(0.7) * glam::DMat4::from_scale(DVec3::splat(0.5));
        let q = polar_rotation(DMat3::from_mat4(rotated));
        assert!(q.abs_diff_eq(DMat3::from_rotation_x(0.7), 1e-12));
    }

    #[test]
    fn layouts_are_checked_by_position() {
        let mut t = table(&[row([0.0; 3], [1.0; 3], [1.0, 0.0, 0.0, 0.0])]);
        assert!(Layout::of(&t).unwrap().opacity.is_none());
        t.names.swap(6, 9);
        let e = Layout::of(&t).err().unwrap();
        assert!(e.contains("must begin with x y z nx ny nz"), "{e}");
        assert!((adaptive_extent(sigmoid(0.5), 3.0) - 2.87440).abs() < 1e-4);
        assert_eq!(adaptive_extent(0.005, 3.0), 0.0);
    }
}
