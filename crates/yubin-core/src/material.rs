//! The scene's material tables: BSDFs, textures and the images textures
//! read. BSDF and texture variants are small `Copy` values that refer to one
//! another (a `twosided`'s children, a texturable parameter) by index in
//! these tables, so every BSDF and texture method takes [`Materials`].

use crate::bsdf::Bsdf;
use crate::texture::{TexImage, Texture};

/// BSDFs, textures and texture images, by index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Materials {
    /// BSDF table (shapes and composite BSDFs refer to it).
    pub bsdfs: Vec<Bsdf>,
    /// Texture table ([`crate::texture::Tex::Texture`] refers to it).
    pub textures: Vec<Texture>,
    /// Images read by textures.
    pub images: Vec<TexImage>,
}

impl Materials {
    /// Tables holding only these BSDFs (for tests and simple scenes).
    pub fn with_bsdfs(bsdfs: Vec<Bsdf>) -> Self {
        Self {
            bsdfs,
            ..Self::default()
        }
    }
}
