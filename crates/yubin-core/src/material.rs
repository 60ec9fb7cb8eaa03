//! The scene's material tables: BSDFs, textures and the images textures
//! read. BSDF and texture variants are small `Copy` values that refer to one
//! another (a `twosided`'s children, a texturable parameter) by index in
//! these tables, so every BSDF and texture method takes [`Materials`].
//! Mesh attributes live here too: textures see only these tables.
//! What a BSDF precomputes from these tables (the layer tables of
//! `roughplastic`, the plastics' sampling weights) is computed when the
//! BSDF is added ([`Materials::add_bsdf`]).

use crate::bsdf::Material;
use crate::texture::{MeshAttributes, TexImage, Texture};

/// BSDFs, textures and texture images, by index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Materials {
    /// BSDF table (shapes and composite BSDFs refer to it).
    pub bsdfs: Vec<Material>,
    /// Texture table ([`crate::texture::Tex::Texture`] refers to it).
    pub textures: Vec<Texture>,
    /// Images read by textures.
    pub images: Vec<TexImage>,
    /// Named mesh attributes (vertex colours, …) that `mesh_attribute`
    /// textures read; meshes and hits refer to their set by index.
    pub attributes: MeshAttributes,
}

impl Materials {
    /// No tables: the materials of an empty scene, for contexts that
    /// need a `'static` reference.
    pub const EMPTY: Materials = Materials {
        bsdfs: Vec::new(),
        textures: Vec::new(),
        images: Vec::new(),
        attributes: MeshAttributes::EMPTY,
    };

    /// Tables holding only these BSDFs (for tests and simple scenes).
    pub fn with_bsdfs(bsdfs: Vec<Material>) -> Self {
        let mut m = Self::default();
        for b in bsdfs {
            m.add_bsdf(b);
        }
        m
    }

    /// Adds a BSDF, computing the tables it needs from the textures
    /// already present (so add textures first); returns its index.
    pub fn add_bsdf(&mut self, mut b: Material) -> u32 {
        b.prepare(self);
        self.bsdfs.push(b);
        self.bsdfs.len() as u32 - 1
    }

    /// Puts `b` in place of BSDF `index`, with the tables it needs.
    pub fn replace_bsdf(&mut self, index: u32, mut b: Material) {
        b.prepare(self);
        self.bsdfs[index as usize] = b;
    }

    /// Makes every BSDF's tables again (after a texture changed).
    pub fn prepare_bsdfs(&mut self) {
        for i in 0..self.bsdfs.len() {
            let mut b = self.bsdfs[i];
            b.prepare(self);
            self.bsdfs[i] = b;
        }
    }
}
