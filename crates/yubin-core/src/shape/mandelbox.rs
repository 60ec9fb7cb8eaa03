//! `mandelbox`: the Mandelbox fractal (Tom Lowe, 2010), ray marched by
//! its distance estimator. A shape of its own, or a node of an `sdf`
//! tree (`<sdf type="mandelbox">`) so that it can be carved with boxes.
//!
//! | parameter       | type    | default | meaning |
//! |-----------------|---------|---------|---------|
//! | `scale`         | float   | 2       | the scale of each iteration; \|scale\| > 1 |
//! | `folding_limit` | float   | 1       | the box fold reflects coordinates beyond ±limit |
//! | `min_radius`    | float   | 0.5     | inside this radius the sphere fold scales by (fixed/min)² |
//! | `fixed_radius`  | float   | 1       | between min and fixed radius it inverts in the sphere |
//! | `iterations`    | integer | 12      | iterations of the fold (1 to 100) |
//! | `half_extent`   | float   | computed | half the side of the cube that holds it (see below) |
//!
//! As a shape, it also takes the `sdf` shape's marching parameters
//! (`step_factor`, `epsilon`, `max_steps`, `to_world`, `uv_scale`,
//! `flip_normals`).
//!
//! ```xml
//! <shape type="mandelbox">
//!     <float name="scale" value="2"/>
//!     <integer name="iterations" value="12"/>
//!     <float name="step_factor" value="0.9"/>
//!     <transform name="to_world"><scale value="0.1"/></transform>
//! </shape>
//! ```
//!
//! Each iteration folds z = clamp(z, −L, L)·2 − z (box fold), then
//! scales it by (fixed/min)² inside the minimum radius or inverts it in
//! the fixed sphere between the two (sphere fold), then z = scale·z + p.
//! The running derivative dr follows the same scalings
//! (dr ← dr·|scale| + 1), and the estimate is |z| / |dr| (Hart, Sandin and Kauffman 1989,
//! "Ray tracing deterministic 3-D fractals"; the Mandelbox form as
//! explained by Christensen, "Distance estimated 3D fractals VI: the
//! Mandelbox", 2011). Iteration stops once |z|² exceeds 10⁶, where the
//! estimate has converged.
//!
//! The estimate is not a strict bound everywhere: marching 400 random
//! rays with `step_factor` 1 or 0.9, 2 stepped over the surface that
//! fine stepping finds; at 0.8 none did, so 0.8 is the default step of
//! any `sdf` tree holding a Mandelbox (`mandelbox_marching_never_overshoots`).
//!
//! The default extent is 2(s + 1)/(s − 1) times the folding limit for a
//! scale s > 1 and 2.05 times the folding limit for s < −1 (of 400,000
//! random points, none in the set lay beyond 2, but points just outside
//! 2 escape slowly: at 2.0002, 4 % of those on the faces stayed bounded
//! for 30 iterations, at 2.01 none; `default_extent_holds_the_set`
//! checks that points on the cube's faces escape). Give `half_extent` for
//! other radii. The default extent is 2(|s| + 1)/(|s| − 1)
//! times the folding limit for scale s, which holds the fractal for the
//! default radii (checked by the same test); give `half_extent` for
//! other radii.

use crate::params::{ParamError, Params};
use glam::Vec3;

const BAILOUT2: f32 = 1e6;

/// The Mandelbox's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mandelbox {
    scale: f32,
    folding_limit: f32,
    min_radius2: f32,
    fixed_radius2: f32,
    iterations: u32,
    half_extent: f32,
}

impl Mandelbox {
    /// The fractal with the given scale and iteration count, the other
    /// parameters at their defaults.
    pub fn new(scale: f32, iterations: u32) -> Self {
        Self {
            scale,
            folding_limit: 1.0,
            min_radius2: 0.25,
            fixed_radius2: 1.0,
            iterations,
            half_extent: default_extent(scale, 1.0),
        }
    }

    /// Reads the parameters of the table above.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let scale = p.float_or("scale", 2.0)?;
        if !(scale.is_finite() && scale.abs() > 1.0) {
            return Err(p.param_error("scale", "must be finite with |scale| > 1"));
        }
        let folding_limit = p.positive_float_or("folding_limit", 1.0)?;
        let min_radius = p.positive_float_or("min_radius", 0.5)?;
        let fixed_radius = p.positive_float_or("fixed_radius", 1.0)?;
        if min_radius > fixed_radius {
            return Err(p.param_error("min_radius", "must not exceed fixed_radius"));
        }
        let iterations = p.integer_or("iterations", 12)?;
        if !(1..=100).contains(&iterations) {
            return Err(p.param_error("iterations", "must be between 1 and 100"));
        }
        let half_extent = match p.float("half_extent")? {
            Some(h) if h.is_finite() && h > 0.0 => h,
            Some(_) => return Err(p.param_error("half_extent", "must be positive")),
            None => default_extent(scale, folding_limit),
        };
        Ok(Self {
            scale,
            folding_limit,
            min_radius2: min_radius * min_radius,
            fixed_radius2: fixed_radius * fixed_radius,
            iterations: iterations as u32,
            half_extent,
        })
    }

    /// Half the side of the cube around the origin that holds it.
    pub fn half_extent(&self) -> f32 {
        self.half_extent
    }

    /// Whether `p` stays bounded for all iterations (is in the set).
    pub fn contains(&self, p: Vec3) -> bool {
        let (z, _) = self.iterate(p);
        z.length_squared() <= BAILOUT2
    }

    /// The distance estimate at `p`.
    #[inline]
    pub fn distance(&self, p: Vec3) -> f32 {
        let (z, dr) = self.iterate(p);
        z.length() / dr.abs()
    }

    #[inline]
    fn iterate(&self, p: Vec3) -> (Vec3, f32) {
        let limit = Vec3::splat(self.folding_limit);
        let mut z = p;
        let mut dr = 1.0f32;
        for _ in 0..self.iterations {
            z = z.clamp(-limit, limit) * 2.0 - z;
            let r2 = z.length_squared();
            let k = if r2 < self.min_radius2 {
                self.fixed_radius2 / self.min_radius2
            } else if r2 < self.fixed_radius2 {
                self.fixed_radius2 / r2
            } else {
                1.0
            };
            z = z * (k * self.scale) + p;
            dr = dr * k * self.scale.abs() + 1.0;
            if z.length_squared() > BAILOUT2 {
                break;
            }
        }
        (z, dr)
    }
}

fn default_extent(scale: f32, folding_limit: f32) -> f32 {
    if scale > 1.0 {
        2.0 * (scale + 1.0) / (scale - 1.0) * folding_limit
    } else {
        2.05 * folding_limit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on the faces of the default cube escape (the cube holds the
    /// set), for positive and negative scales.
    #[test]
    fn default_extent_holds_the_set() {
        for scale in [2.0, 3.0, -1.5, -2.0] {
            let m = Mandelbox::new(scale, 30);
            let h = m.half_extent() * 1.0001;
            let mut rng = crate::sampler::Pcg32::new(3, 0);
            for _ in 0..2000 {
                let u = rng.next_2d() * 2.0 - glam::Vec2::ONE;
                let axis = (rng.next_f32() * 3.0) as usize % 3;
                let sign = if rng.next_f32() < 0.5 { -h } else { h };
                let mut p = Vec3::new(u.x * h, u.y * h, u.x * u.y * h);
                p[axis] = sign;
                assert!(!m.contains(p), "scale {scale}: {p} is in the set");
            }
        }
    }
}
