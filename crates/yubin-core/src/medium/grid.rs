//! A voxel grid of one or three channels (densities, albedos), or six (an
//! `sggx` phase function's matrices), as Mitsuba's `gridvolume` holds:
//! values at the voxel centres of a box, read by trilinear interpolation,
//! clamped at the faces.

use crate::math::Bounds3;
use crate::texture::WrapMode;
use crate::Rgb;
use glam::Vec3;

/// Why a grid cannot be made.
#[derive(Clone, Debug, PartialEq)]
pub enum GridError {
    /// A resolution of zero, or channels other than 1, 3 or 6.
    Shape(String),
    /// The data does not hold res.x · res.y · res.z · channels values.
    Size {
        /// Values expected.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// A negative or non-finite value.
    Value {
        /// The voxel (x, y, z).
        voxel: [u32; 3],
        /// The value.
        value: f32,
    },
}

impl std::fmt::Display for GridError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GridError::Shape(msg) => write!(f, "{msg}"),
            GridError::Size { expected, found } => write!(
                f,
                "the grid should hold {expected} values but holds {found} (truncated?)"
            ),
            GridError::Value { voxel, value } => write!(
                f,
                "voxel {voxel:?} holds {value}: volume values must be finite and >= 0"
            ),
        }
    }
}

impl std::error::Error for GridError {}

/// A dense grid of voxel values.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Voxels along x, y and z.
    pub res: [u32; 3],
    /// 1, 3 or 6.
    pub channels: u32,
    /// The box the grid fills (its own space).
    pub bounds: Bounds3,
    /// Values, x fastest, then y, then z, channels interleaved.
    data: Vec<f32>,
    /// The largest value of any channel (a majorant of the whole grid).
    max: f32,
}

impl Grid {
    /// A grid from its values (x fastest, then y, z; channels
    /// interleaved), checked: every value finite and non-negative.
    pub fn new(
        res: [u32; 3],
        channels: u32,
        bounds: Bounds3,
        data: Vec<f32>,
    ) -> Result<Self, GridError> {
        let g = Self::new_signed(res, channels, bounds, data)?;
        g.check_non_negative()?;
        Ok(g)
    }

    /// A grid whose values may be negative (a signed distance grid),
    /// checked: every value finite.
    pub fn new_signed(
        res: [u32; 3],
        channels: u32,
        bounds: Bounds3,
        data: Vec<f32>,
    ) -> Result<Self, GridError> {
        if res.contains(&0) {
            return Err(GridError::Shape(format!("resolution {res:?} has a zero")));
        }
        if ![1, 3, 6].contains(&channels) {
            return Err(GridError::Shape(format!(
                "{channels} channels: a volume has 1 or 3 (6 for an sggx phase function's S)"
            )));
        }
        let expected = res.iter().map(|&r| r as usize).product::<usize>() * channels as usize;
        if data.len() != expected {
            return Err(GridError::Size {
                expected,
                found: data.len(),
            });
        }
        let grid = |data| Self {
            res,
            channels,
            bounds,
            data,
            max: 0.0,
        };
        if let Some(i) = data.iter().position(|v| !v.is_finite()) {
            return Err(grid(Vec::new()).value_error(i, data[i]));
        }
        let max = data.iter().copied().fold(0.0, f32::max);
        Ok(Self { max, ..grid(data) })
    }

    /// An error unless every value is 0 or more (densities, albedos).
    pub fn check_non_negative(&self) -> Result<(), GridError> {
        match self.data.iter().position(|v| *v < 0.0) {
            Some(i) => Err(self.value_error(i, self.data[i])),
            None => Ok(()),
        }
    }

    fn value_error(&self, i: usize, value: f32) -> GridError {
        let voxel = i / self.channels as usize;
        let (x, y) = (self.res[0] as usize, self.res[1] as usize);
        GridError::Value {
            voxel: [
                (voxel % x) as u32,
                (voxel / x % y) as u32,
                (voxel / (x * y)) as u32,
            ],
            value,
        }
    }

    /// The values, x fastest, then y, then z, channels interleaved.
    pub fn values(&self) -> &[f32] {
        &self.data
    }

    /// The largest value in the grid.
    pub fn max(&self) -> f32 {
        self.max
    }

    /// The largest channel of voxel `v` (inside the grid).
    #[inline]
    pub(crate) fn voxel_max(&self, v: [u32; 3]) -> f32 {
        self.voxel(v[0] as i64, v[1] as i64, v[2] as i64)
            .max_element()
    }

    /// The value of voxel (x, y, z), clamped to the grid, as RGB (a single
    /// channel repeated).
    #[inline]
    fn voxel(&self, x: i64, y: i64, z: i64) -> Rgb {
        self.wrapped_voxel(x, y, z, WrapMode::Clamp)
    }

    /// The value of voxel (x, y, z), its indices wrapped by `wrap`.
    #[inline]
    fn wrapped_voxel(&self, x: i64, y: i64, z: i64, wrap: WrapMode) -> Rgb {
        let i = self.wrapped_index(x, y, z, wrap);
        if self.channels == 1 {
            Rgb::splat(self.data[i])
        } else {
            Rgb::from_slice(&self.data[3 * i..3 * i + 3])
        }
    }

    /// The index of voxel (x, y, z), its indices wrapped by `wrap`.
    #[inline]
    fn wrapped_index(&self, x: i64, y: i64, z: i64, wrap: WrapMode) -> usize {
        let (x, y, z) = (
            wrap.index(x, self.res[0]) as usize,
            wrap.index(y, self.res[1]) as usize,
            wrap.index(z, self.res[2]) as usize,
        );
        (z * self.res[1] as usize + y) * self.res[0] as usize + x
    }

    /// The trilinearly interpolated value at `p` (the grid's own space);
    /// zero outside its box.
    pub fn eval(&self, p: Vec3) -> Rgb {
        let b = &self.bounds;
        if !(p.cmpge(b.min).all() && p.cmple(b.max).all()) {
            return Rgb::ZERO;
        }
        self.lookup(p, WrapMode::Clamp, false)
    }

    /// The value at `p` (the grid's own space) anywhere: voxel indices
    /// outside the grid wrap by `wrap` (as a texture's texels do);
    /// trilinear between voxel centres, or the nearest voxel.
    pub fn lookup(&self, p: Vec3, wrap: WrapMode, nearest: bool) -> Rgb {
        self.interpolate(p, nearest, |x, y, z| self.wrapped_voxel(x, y, z, wrap))
    }

    /// [`Grid::lookup`] of a six-channel grid.
    pub fn lookup6(&self, p: Vec3, wrap: WrapMode, nearest: bool) -> [f32; 6] {
        debug_assert_eq!(self.channels, 6);
        self.interpolate(p, nearest, |x, y, z| {
            let i = 6 * self.wrapped_index(x, y, z, wrap);
            Six(self.data[i..i + 6].try_into().unwrap())
        })
        .0
    }

    /// Trilinear interpolation (or the nearest voxel) of the values
    /// `voxel` gives by voxel index, at `p` in the grid's own space.
    #[inline]
    fn interpolate<T: Lerp>(
        &self,
        p: Vec3,
        nearest: bool,
        voxel: impl Fn(i64, i64, i64) -> T,
    ) -> T {
        let b = &self.bounds;
        let res = Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32);
        // Voxel centres sit at (i + 1/2) / res of the box.
        let q = (p - b.min) / (b.max - b.min) * res;
        if nearest {
            let v = crate::math::floor3(q);
            return voxel(v.x as i64, v.y as i64, v.z as i64);
        }
        let q = q - Vec3::splat(0.5);
        let base = crate::math::floor3(q);
        let f = q - base;
        let (x, y, z) = (base.x as i64, base.y as i64, base.z as i64);
        let plane = |dz: i64| {
            let row =
                |dy: i64| T::lerp(voxel(x, y + dy, z + dz), voxel(x + 1, y + dy, z + dz), f.x);
            T::lerp(row(0), row(1), f.y)
        };
        T::lerp(plane(0), plane(1), f.z)
    }
}

/// Values interpolated between voxels.
trait Lerp: Copy {
    fn lerp(a: Self, b: Self, t: f32) -> Self;
}

impl Lerp for Rgb {
    #[inline]
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        a + (b - a) * t
    }
}

/// A six-channel voxel.
#[derive(Clone, Copy)]
struct Six([f32; 6]);

impl Lerp for Six {
    #[inline]
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        Six(std::array::from_fn(|i| a.0[i] + (b.0[i] - a.0[i]) * t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> Bounds3 {
        Bounds3 {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        }
    }

    #[test]
    fn trilinear_at_centres_between_and_outside() {
        // 2 × 1 × 1, values 1 and 3: centres at x = 1/4 and 3/4.
        let g = Grid::new([2, 1, 1], 1, unit_box(), vec![1.0, 3.0]).unwrap();
        assert_eq!(g.eval(Vec3::new(0.25, 0.5, 0.5)), Rgb::splat(1.0));
        assert_eq!(g.eval(Vec3::new(0.5, 0.5, 0.5)), Rgb::splat(2.0));
        assert_eq!(g.eval(Vec3::new(0.9, 0.1, 0.9)), Rgb::splat(3.0));
        assert_eq!(g.eval(Vec3::new(1.1, 0.5, 0.5)), Rgb::ZERO);
        assert_eq!(g.max(), 3.0);
        let rgb = Grid::new([1, 1, 2], 3, unit_box(), vec![0.0, 1.0, 2.0, 2.0, 3.0, 4.0]).unwrap();
        assert_eq!(rgb.eval(Vec3::new(0.5, 0.5, 0.5)), Rgb::new(1.0, 2.0, 3.0));
    }

    /// Outside the box, voxel indices wrap as a texture's texels do.
    #[test]
    fn lookups_wrap_outside_the_box() {
        let g = Grid::new([2, 1, 1], 1, unit_box(), vec![1.0, 3.0]).unwrap();
        let at = |x: f32, wrap| g.lookup(Vec3::new(x, 0.5, 0.5), wrap, false).x;
        // x = 1.25 is the centre of voxel 2: voxel 0 repeated, voxel 1
        // mirrored or clamped.
        assert_eq!(at(1.25, WrapMode::Repeat), 1.0);
        assert_eq!(at(1.25, WrapMode::Mirror), 3.0);
        assert_eq!(at(1.25, WrapMode::Clamp), 3.0);
        assert_eq!(at(-0.25, WrapMode::Repeat), 3.0);
        // Between voxel 1 and the repeated voxel 0.
        assert_eq!(at(1.0, WrapMode::Repeat), 2.0);
        let nearest = |x: f32| g.lookup(Vec3::new(x, 0.5, 0.5), WrapMode::Clamp, true).x;
        assert_eq!((nearest(0.49), nearest(0.51)), (1.0, 3.0));
    }

    #[test]
    fn bad_grids_are_refused() {
        let b = unit_box();
        assert!(matches!(
            Grid::new([0, 1, 1], 1, b, vec![]),
            Err(GridError::Shape(_))
        ));
        assert!(matches!(
            Grid::new([1, 1, 1], 2, b, vec![0.0; 2]),
            Err(GridError::Shape(_))
        ));
        assert_eq!(
            Grid::new([2, 2, 1], 1, b, vec![0.0; 3]),
            Err(GridError::Size {
                expected: 4,
                found: 3
            })
        );
        assert_eq!(
            Grid::new([2, 2, 1], 1, b, vec![0.0, 0.0, 0.0, -1.0]),
            Err(GridError::Value {
                voxel: [1, 1, 0],
                value: -1.0
            })
        );
        assert!(Grid::new([1, 1, 1], 3, b, vec![0.0, f32::NAN, 0.0]).is_err());
    }
}
