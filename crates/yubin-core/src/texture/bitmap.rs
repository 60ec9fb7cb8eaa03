//! `bitmap`: an image texture.
//!
//! | parameter     | type      | default    | meaning                                                        |
//! |---------------|-----------|------------|----------------------------------------------------------------|
//! | `filename`    | string    | (required) | PNG, JPEG, EXR, Radiance HDR, PFM, BMP or TGA file             |
//! | `filter_type` | string    | `bilinear` | `bilinear` or `nearest` (texel lookup)                         |
//! | `wrap_mode`   | string    | `repeat`   | `repeat`, `mirror` or `clamp`, outside [0, 1]²                  |
//! | `raw`         | boolean   | false      | use 8-bit values as they are instead of decoding sRGB           |
//! | `to_uv`       | transform | identity   | applied to the surface's uv before the lookup                  |
//!
//! ```xml
//! <texture type="bitmap" name="reflectance">
//!     <string name="filename" value="textures/wood.jpg"/>
//!     <transform name="to_uv"><scale x="4" y="4"/></transform>
//! </texture>
//! ```
//!
//! uv (0, 0) is the top-left corner of the image. Bilinear filtering blends
//! the four texels around `uv · size − ½` after decoding them, so 8-bit
//! sRGB maps are interpolated in linear space (as Mitsuba 3 does); the
//! image itself stays 8 bits per channel in memory. As a float (roughness,
//! opacity, bump height) a one-channel image gives its value and a colour
//! image its luminance. Mitsuba 3's `bitmap` plugin.

use super::{uv_transform_param, TexImage, TextureModel};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::spectrum::luminance;
use crate::Rgb;
use glam::{Affine2, Vec2, Vec4};

/// Texel lookup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterType {
    /// Bilinear interpolation of the four nearest texels.
    Bilinear,
    /// The texel under the point.
    Nearest,
}

/// What happens outside [0, 1]².
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WrapMode {
    /// Tile the image.
    Repeat,
    /// Tile with every other copy mirrored.
    Mirror,
    /// Extend the border texels.
    Clamp,
}

impl WrapMode {
    /// Index `i` of a row of `n` texels (or voxels) wrapped into 0..n.
    #[inline]
    pub fn index(self, i: i64, n: u32) -> u32 {
        let n = n as i64;
        // Most lookups land inside: no 64-bit division for them (nor for
        // the column just left of the first, an environment map's seam).
        if (0..n).contains(&i) {
            return i as u32;
        }
        if i == -1 && self == WrapMode::Repeat {
            return (n - 1) as u32;
        }
        let w = match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                let j = i.rem_euclid(2 * n);
                if j >= n {
                    2 * n - 1 - j
                } else {
                    j
                }
            }
        };
        w as u32
    }
}

/// An image texture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bitmap {
    /// Index in [`Materials::images`].
    pub image: u32,
    /// Texel lookup.
    pub filter: FilterType,
    /// Outside [0, 1]², along u and along v (a scene file's `wrap_mode`
    /// sets both; glTF samplers set them apart).
    pub wrap: [WrapMode; 2],
    /// Keep 8-bit values as they are (no sRGB decoding).
    pub raw: bool,
    /// Applied to uv before the lookup.
    pub to_uv: Affine2,
}

impl Bitmap {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let image = p
            .image("filename")?
            .ok_or_else(|| p.error("needs a \"filename\""))?;
        let filter = match p.choice("filter_type", &["bilinear", "nearest"])? {
            0 => FilterType::Bilinear,
            _ => FilterType::Nearest,
        };
        let wrap = match p.choice("wrap_mode", &["repeat", "mirror", "clamp"])? {
            0 => WrapMode::Repeat,
            1 => WrapMode::Mirror,
            _ => WrapMode::Clamp,
        };
        let raw = p.boolean_or("raw", false)?;
        let to_uv = uv_transform_param(p)?;
        // Mitsuba-only switches with no effect here.
        p.mark_ignored("accel");
        p.mark_ignored("format");
        Ok(Self {
            image,
            filter,
            wrap: [wrap; 2],
            raw,
            to_uv,
        })
    }

    /// Texel `i` of `n` along `axis` (0: u, 1: v), wrapped.
    #[inline]
    fn wrap_index(&self, axis: usize, i: i64, n: u32) -> u32 {
        self.wrap[axis].index(i, n)
    }

    /// The four texels around `uv` and the bilinear weights, or the texel
    /// under `uv` (with weights (0, 0)) for nearest filtering.
    #[inline]
    fn corners(&self, img: &TexImage, uv: Vec2) -> ([Vec4; 4], Vec2) {
        let decode = !self.raw;
        let size = Vec2::new(img.width as f32, img.height as f32);
        match self.filter {
            FilterType::Nearest => {
                let p = crate::math::floor2(uv * size);
                let x = self.wrap_index(0, p.x as i64, img.width);
                let y = self.wrap_index(1, p.y as i64, img.height);
                let t = img.texel(x, y, decode);
                ([t; 4], Vec2::ZERO)
            }
            FilterType::Bilinear => {
                let p = uv * size - 0.5;
                let p0 = crate::math::floor2(p);
                let f = p - p0;
                let (x0, y0) = (p0.x as i64, p0.y as i64);
                let xs = [x0, x0 + 1].map(|x| self.wrap_index(0, x, img.width));
                let ys = [y0, y0 + 1].map(|y| self.wrap_index(1, y, img.height));
                (
                    [
                        img.texel(xs[0], ys[0], decode),
                        img.texel(xs[1], ys[0], decode),
                        img.texel(xs[0], ys[1], decode),
                        img.texel(xs[1], ys[1], decode),
                    ],
                    f,
                )
            }
        }
    }

    #[inline]
    fn lookup(&self, m: &Materials, si: &SurfaceInteraction) -> Vec4 {
        let img = &m.images[self.image as usize];
        let uv = self.to_uv.transform_point2(si.uv);
        if !uv.is_finite() {
            return Vec4::ZERO;
        }
        let ([t00, t10, t01, t11], f) = self.corners(img, uv);
        let top = t00.lerp(t10, f.x);
        let bottom = t01.lerp(t11, f.x);
        top.lerp(bottom, f.y)
    }

    fn is_grey(&self, m: &Materials) -> bool {
        m.images[self.image as usize].channels <= 2
    }

    #[inline]
    fn scalar(&self, m: &Materials, v: Vec4) -> f32 {
        if self.is_grey(m) {
            v.x
        } else {
            luminance(v.truncate())
        }
    }
}

impl TextureModel for Bitmap {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        self.lookup(m, si).truncate()
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        let v = self.lookup(m, si);
        self.scalar(m, v)
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        let img = &m.images[self.image as usize];
        let uv = self.to_uv.transform_point2(si.uv);
        if !uv.is_finite() {
            return (0.0, Vec2::ZERO);
        }
        let ([t00, t10, t01, t11], f) = self.corners(img, uv);
        let [v00, v10, v01, v11] = [t00, t10, t01, t11].map(|t| self.scalar(m, t));
        let value =
            (v00 * (1.0 - f.x) + v10 * f.x) * (1.0 - f.y) + (v01 * (1.0 - f.x) + v11 * f.x) * f.y;
        if self.filter == FilterType::Nearest {
            return (value, Vec2::ZERO);
        }
        // Derivative with respect to the transformed uv, then the chain
        // rule through to_uv's linear part.
        let d_tex = Vec2::new(
            img.width as f32 * ((v10 - v00) * (1.0 - f.y) + (v11 - v01) * f.y),
            img.height as f32 * ((v01 - v00) * (1.0 - f.x) + (v11 - v10) * f.x),
        );
        let j = self.to_uv.matrix2;
        (value, Vec2::new(j.x_axis.dot(d_tex), j.y_axis.dot(d_tex)))
    }

    fn mean(&self, m: &Materials) -> f32 {
        let img = &m.images[self.image as usize];
        let means = if self.raw {
            img.mean_raw
        } else {
            img.mean_linear
        };
        if img.channels <= 2 {
            means[0]
        } else {
            luminance(Rgb::new(means[0], means[1], means[2]))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::tests::flat_si;
    use crate::texture::image::ImageData;

    fn materials(data: Vec<f32>, w: u32, h: u32, c: u32) -> Materials {
        Materials {
            images: vec![TexImage::new(w, h, c, ImageData::F32(data), false).unwrap()],
            ..Materials::default()
        }
    }

    fn at(uv: Vec2) -> SurfaceInteraction {
        SurfaceInteraction { uv, ..flat_si() }
    }

    fn bitmap(filter: FilterType, wrap: WrapMode) -> Bitmap {
        Bitmap {
            image: 0,
            filter,
            wrap: [wrap; 2],
            raw: false,
            to_uv: Affine2::IDENTITY,
        }
    }

    #[test]
    fn bilinear_interpolates_between_texel_centres() {
        // 2×1: 0 on the left, 1 on the right.
        let m = materials(vec![0.0, 1.0], 2, 1, 1);
        let b = bitmap(FilterType::Bilinear, WrapMode::Clamp);
        assert_eq!(b.eval_1(&m, &at(Vec2::new(0.25, 0.5))), 0.0);
        assert_eq!(b.eval_1(&m, &at(Vec2::new(0.75, 0.5))), 1.0);
        assert!((b.eval_1(&m, &at(Vec2::new(0.5, 0.5))) - 0.5).abs() < 1e-6);
        let (v, g) = b.eval_1_grad(&m, &at(Vec2::new(0.5, 0.5)));
        assert!((v - 0.5).abs() < 1e-6);
        assert!((g - Vec2::new(2.0, 0.0)).length() < 1e-4, "{g}");
    }

    #[test]
    fn wrap_modes() {
        let m = materials(vec![0.0, 1.0], 2, 1, 1);
        let uv = Vec2::new(1.25, 0.5); // a quarter into the next tile
        let near = |w| bitmap(FilterType::Nearest, w).eval_1(&m, &at(uv));
        assert_eq!(near(WrapMode::Repeat), 0.0);
        assert_eq!(near(WrapMode::Mirror), 1.0);
        assert_eq!(near(WrapMode::Clamp), 1.0);
        // Each axis by its own mode: u repeats, v clamps.
        let m = materials(vec![0.0, 1.0, 2.0, 3.0], 2, 2, 1);
        let b = Bitmap {
            wrap: [WrapMode::Repeat, WrapMode::Clamp],
            ..bitmap(FilterType::Nearest, WrapMode::Repeat)
        };
        let texel = |u: f32, v: f32| b.eval_1(&m, &at(Vec2::new(u, v)));
        assert_eq!(texel(1.25, 0.25), texel(0.25, 0.25));
        assert_eq!(texel(0.25, 1.25), texel(0.25, 0.75));
        assert_ne!(texel(0.25, 1.25), texel(0.25, 0.25));
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let data: Vec<f32> = (0..16).map(|i| ((i * 7) % 5) as f32 / 4.0).collect();
        let m = materials(data, 4, 4, 1);
        let mut b = bitmap(FilterType::Bilinear, WrapMode::Repeat);
        b.to_uv = Affine2::from_cols_array(&[2.0, 0.5, -0.3, 1.5, 0.1, 0.2]);
        let uv = Vec2::new(0.33, 0.61);
        let (_, g) = b.eval_1_grad(&m, &at(uv));
        let h = 1e-3;
        let du =
            (b.eval_1(&m, &at(uv + Vec2::X * h)) - b.eval_1(&m, &at(uv - Vec2::X * h))) / (2.0 * h);
        let dv =
            (b.eval_1(&m, &at(uv + Vec2::Y * h)) - b.eval_1(&m, &at(uv - Vec2::Y * h))) / (2.0 * h);
        assert!(
            (g - Vec2::new(du, dv)).length() < 1e-2 * (1.0 + g.length()),
            "{g} vs {du}, {dv}"
        );
    }
}
