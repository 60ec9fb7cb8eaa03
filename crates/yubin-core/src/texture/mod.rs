//! Textures: spatially varying parameters. The contract every texture
//! implements ([`TextureModel`]), the closed enum the scene stores
//! ([`Texture`]), and [`Tex`], the value of a texturable parameter: a
//! constant or a texture by index in [`Materials::textures`].
//!
//! Conventions (Mitsuba 3's):
//! - `uv` come from the surface interaction; (0, 0) is the image's top-left
//!   corner, u to the right, v down (OBJ files are flipped at load time by
//!   `flip_tex_coords`, as in Mitsuba).
//! - [`TextureModel::eval_1`] of a colour texture is its luminance, so the
//!   same texture can drive a colour or a float parameter (roughness,
//!   opacity, bump height).
//! - [`TextureModel::eval_1_grad`] is the derivative of `eval_1` with respect
//!   to (u, v), for bump mapping.
//! - [`TextureModel::mean`] is the average value over the texture's domain,
//!   for sampling weights (`plastic`).

mod bitmap;
mod checkerboard;
mod fbm;
mod grid;
pub mod image;
mod mesh_attribute;
mod mix;
pub mod noise;
mod normal_deviation;
mod perlin;
mod rawconstant;
mod scale;
mod volume;

pub use bitmap::{Bitmap, FilterType, WrapMode};
pub use checkerboard::Checkerboard;
pub use fbm::Fbm;
pub use grid::Grid;
pub use image::TexImage;
pub use mesh_attribute::{
    AttributeSlot, MeshAttribute, MeshAttributes, NamedAttribute, NO_ATTRIBUTES,
};
pub use mix::Mix;
pub use noise::{NoiseMap, NoiseSpace};
pub use normal_deviation::NormalDeviation;
pub use perlin::Perlin;
pub use rawconstant::RawConstant;
pub use scale::Scale;
pub use volume::VolumeTexture;

use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::spectrum::luminance;
use crate::Rgb;
use glam::{Affine2, DMat4, Vec2};

/// The contract of every texture.
pub trait TextureModel {
    /// The colour at `si`.
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb;
    /// A single value at `si` (the luminance of a colour texture).
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        luminance(self.eval(m, si))
    }
    /// `eval_1` and its derivative with respect to (u, v).
    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2);
    /// The mean of `eval_1` over the texture's domain.
    fn mean(&self, m: &Materials) -> f32;
}

/// A texture (closed enum; see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Texture {
    /// `bitmap`.
    Bitmap(Bitmap),
    /// `checkerboard`.
    Checkerboard(Checkerboard),
    /// `fbm`.
    Fbm(Fbm),
    /// `grid`.
    Grid(Grid),
    /// `mesh_attribute`.
    MeshAttribute(MeshAttribute),
    /// `mix`.
    Mix(Mix),
    /// `normal_deviation`.
    NormalDeviation(NormalDeviation),
    /// `perlin`.
    Perlin(Perlin),
    /// `scale`.
    Scale(Scale),
    /// `rawconstant`.
    RawConstant(RawConstant),
    /// `volume`.
    Volume(VolumeTexture),
}

macro_rules! dispatch {
    ($self:expr, $t:ident => $e:expr) => {
        match $self {
            Texture::Bitmap($t) => $e,
            Texture::Checkerboard($t) => $e,
            Texture::Volume($t) => $e,
            Texture::Fbm($t) => $e,
            Texture::Grid($t) => $e,
            Texture::MeshAttribute($t) => $e,
            Texture::Mix($t) => $e,
            Texture::NormalDeviation($t) => $e,
            Texture::Perlin($t) => $e,
            Texture::Scale($t) => $e,
            Texture::RawConstant($t) => $e,
        }
    };
}

impl TextureModel for Texture {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        dispatch!(self, t => t.eval(m, si))
    }
    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        dispatch!(self, t => t.eval_1(m, si))
    }
    #[inline]
    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        dispatch!(self, t => t.eval_1_grad(m, si))
    }
    fn mean(&self, m: &Materials) -> f32 {
        dispatch!(self, t => t.mean(m))
    }
}

/// The value of a texturable parameter: a constant (a float is stored as a
/// grey colour) or a texture by index in [`Materials::textures`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tex {
    /// The same colour everywhere.
    Const(Rgb),
    /// A texture of the scene.
    Texture(u32),
}

impl From<Rgb> for Tex {
    fn from(c: Rgb) -> Self {
        Tex::Const(c)
    }
}

impl Tex {
    /// A constant grey value.
    pub fn value(v: f32) -> Self {
        Tex::Const(Rgb::splat(v))
    }

    /// The colour at `si`.
    #[inline]
    pub fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        match *self {
            Tex::Const(c) => c,
            Tex::Texture(t) => m.textures[t as usize].eval(m, si),
        }
    }

    /// The value at `si` (the luminance of a colour; a float constant is
    /// grey, whose luminance is the float).
    #[inline]
    pub fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        match *self {
            Tex::Const(c) => luminance(c),
            Tex::Texture(t) => m.textures[t as usize].eval_1(m, si),
        }
    }

    /// `eval_1` and its (u, v) derivative.
    #[inline]
    pub fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        match *self {
            Tex::Const(c) => (luminance(c), Vec2::ZERO),
            Tex::Texture(t) => m.textures[t as usize].eval_1_grad(m, si),
        }
    }

    /// The mean value over the domain.
    pub fn mean(&self, m: &Materials) -> f32 {
        match *self {
            Tex::Const(c) => luminance(c),
            Tex::Texture(t) => m.textures[t as usize].mean(m),
        }
    }

    /// The pixel size of the image behind a `bitmap` texture; `None` for
    /// constants and procedural textures.
    pub fn resolution(&self, m: &Materials) -> Option<[u32; 2]> {
        match *self {
            Tex::Texture(t) => match m.textures.get(t as usize)? {
                Texture::Bitmap(b) => {
                    let img = m.images.get(b.image as usize)?;
                    Some([img.width, img.height])
                }
                _ => None,
            },
            Tex::Const(_) => None,
        }
    }

    /// The constant value, if it is one.
    pub fn as_const(&self) -> Option<Rgb> {
        match *self {
            Tex::Const(c) => Some(c),
            Tex::Texture(_) => None,
        }
    }

    /// The texture index this refers to, if any (for index checks).
    pub fn texture_index(&self) -> Option<u32> {
        match *self {
            Tex::Const(_) => None,
            Tex::Texture(t) => Some(t),
        }
    }
}

/// Mitsuba's `to_uv`: the 2D affine part (rows and columns x, y and the
/// translation) of a 4×4 transform.
pub fn uv_transform(m: &DMat4) -> Affine2 {
    let m = m.as_mat4();
    Affine2::from_cols(
        Vec2::new(m.x_axis.x, m.x_axis.y),
        Vec2::new(m.y_axis.x, m.y_axis.y),
        Vec2::new(m.w_axis.x, m.w_axis.y),
    )
}

/// Reads the `to_uv` parameter (identity when absent).
pub(crate) fn uv_transform_param(
    p: &mut dyn crate::params::Params,
) -> Result<Affine2, crate::params::ParamError> {
    Ok(p.transform("to_uv")?
        .map_or(Affine2::IDENTITY, |m| uv_transform(&m)))
}

/// Builds texture plugin `plugin_type` from its parameters; `None` for an
/// unknown type.
pub type TextureFromParams =
    fn(&mut dyn crate::params::Params) -> Result<Texture, crate::params::ParamError>;

/// Every texture plugin: its scene type string and constructor.
pub const PLUGINS: &[(&str, TextureFromParams)] = &[
    ("bitmap", |p| Ok(Texture::Bitmap(Bitmap::from_params(p)?))),
    ("checkerboard", |p| {
        Ok(Texture::Checkerboard(Checkerboard::from_params(p)?))
    }),
    ("fbm", |p| Ok(Texture::Fbm(Fbm::from_params(p)?))),
    ("grid", |p| Ok(Texture::Grid(Grid::from_params(p)?))),
    ("mesh_attribute", |p| {
        Ok(Texture::MeshAttribute(MeshAttribute::from_params(p)?))
    }),
    ("mix", |p| Ok(Texture::Mix(Mix::from_params(p)?))),
    ("normal_deviation", |p| {
        Ok(Texture::NormalDeviation(NormalDeviation::from_params(p)?))
    }),
    ("perlin", |p| Ok(Texture::Perlin(Perlin::from_params(p)?))),
    ("rawconstant", |p| {
        Ok(Texture::RawConstant(RawConstant::from_params(p)?))
    }),
    ("scale", |p| Ok(Texture::Scale(Scale::from_params(p)?))),
    ("volume", |p| {
        Ok(Texture::Volume(VolumeTexture::from_params(p)?))
    }),
];
