//! Volumes (closed enum): values that vary through space — a medium's
//! extinction, albedo or emitted radiance — one plugin per file
//! (`constvolume`, `gridvolume`, `pyroclastic`), read in world space.
//!
//! Wherever a medium takes a volume, a plain number or colour is a
//! `constvolume` of that value (as in Mitsuba 3).

mod constvolume;
mod gridvolume;
mod pyroclastic;

pub use gridvolume::{placed_grid, GridVolume};
pub use pyroclastic::PyroclasticVolume;

use crate::math::{Bounds3, Transform};
use crate::params::{plugin_of, ColorKind, Family, ParamError, Params};
use crate::Rgb;
use glam::Vec3;

/// A volume.
#[derive(Clone, Debug, PartialEq)]
pub enum Volume {
    /// `constvolume`: the same value everywhere.
    Const(Rgb),
    /// `gridvolume`: a voxel grid.
    Grid(GridVolume),
    /// `pyroclastic`: seed 003's procedural cloud.
    Pyroclastic(PyroclasticVolume),
}

/// Builds a volume plugin from its parameters.
pub type VolumeFromParams = fn(&mut dyn Params) -> Result<Volume, ParamError>;

/// Every volume plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, VolumeFromParams)] = &[
    ("constvolume", constvolume::from_params),
    ("gridvolume", gridvolume::from_params),
    ("pyroclastic", pyroclastic::from_params),
];

/// Builds the volume `p` describes, by its plugin type.
pub fn from_params(p: &mut dyn Params) -> Result<Volume, ParamError> {
    plugin_of(p, "volume", PLUGINS, None)?(p)
}

/// The volume parameter `name`: a nested `<volume name="...">`, or a number
/// or colour (a constant volume), or `default`.
pub fn volume_param(
    p: &mut dyn Params,
    name: &str,
    kind: ColorKind,
    default: Rgb,
) -> Result<Volume, ParamError> {
    if let Some(mut child) = p.named_child(Family::Volume, name)? {
        return from_params(&mut *child);
    }
    Ok(Volume::Const(p.color_or(name, kind, default)?))
}

impl Volume {
    /// The value at world point `p`.
    #[inline]
    pub fn eval(&self, p: Vec3) -> Rgb {
        match self {
            Volume::Const(v) => *v,
            Volume::Grid(g) => g.eval(p),
            Volume::Pyroclastic(c) => c.eval(p),
        }
    }

    /// The largest value of any channel anywhere.
    pub fn max(&self) -> f32 {
        match self {
            Volume::Const(v) => v.max_element(),
            Volume::Grid(g) => g.grid.max(),
            Volume::Pyroclastic(c) => c.max(),
        }
    }

    /// The mean luminance over the volume's box (16³ points, its value
    /// for a constant volume).
    pub fn mean_luminance(&self) -> f32 {
        let Some((to_world, b)) = self.extent() else {
            return crate::spectrum::luminance(self.eval(Vec3::ZERO));
        };
        let n = 16;
        let mut sum = 0.0f64;
        for i in 0..n * n * n {
            let t = Vec3::new((i % n) as f32, (i / n % n) as f32, (i / (n * n)) as f32);
            let local = b.min + (b.max - b.min) * (t + 0.5) / n as f32;
            let p = to_world.m.transform_point3(local);
            sum += f64::from(crate::spectrum::luminance(self.eval(p)));
        }
        (sum / (n * n * n) as f64) as f32
    }

    /// A box (in the volume's own space, with the map from world space to
    /// it) that holds all of the volume a medium reads: heterogeneous media
    /// are empty outside it (as Mitsuba's are outside their volume's
    /// bounding box). `None`: unbounded.
    pub fn extent(&self) -> Option<(Transform, Bounds3)> {
        match self {
            Volume::Const(_) => None,
            Volume::Grid(g) => Some((g.to_world, g.grid.bounds)),
            Volume::Pyroclastic(c) => Some((c.to_world, c.local_bounds())),
        }
    }
}

/// A `to_world` transform's inverse applied to a point.
#[inline]
fn to_local(t: &Transform, p: Vec3) -> Vec3 {
    t.inv.transform_point3(p)
}
