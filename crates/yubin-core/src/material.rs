//! The scene's material tables: BSDFs, textures and the images textures
//! read. BSDF and texture variants are small `Copy` values that refer to one
//! another (a `twosided`'s children, a texturable parameter) by index in
//! these tables, so every BSDF and texture method takes [`Materials`].
//! Mesh attributes live here too: textures see only these tables.
//! Data a BSDF precomputes for itself (the layer tables of `roughplastic`)
//! lives here too, computed when the BSDF is added ([`Materials::add_bsdf`]).

use crate::bsdf::{Bsdf, RoughTransmittance};
use crate::texture::{MeshAttributes, TexImage, Texture};

/// BSDFs, textures and texture images, by index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Materials {
    /// BSDF table (shapes and composite BSDFs refer to it).
    pub bsdfs: Vec<Bsdf>,
    /// Texture table ([`crate::texture::Tex::Texture`] refers to it).
    pub textures: Vec<Texture>,
    /// Images read by textures.
    pub images: Vec<TexImage>,
    /// Transmittance tables of rough dielectric layers (`roughplastic`),
    /// shared by the BSDFs with the same interface.
    pub rough_transmittance: Vec<RoughTransmittance>,
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
        rough_transmittance: Vec::new(),
        attributes: MeshAttributes::EMPTY,
    };

    /// Tables holding only these BSDFs (for tests and simple scenes).
    pub fn with_bsdfs(bsdfs: Vec<Bsdf>) -> Self {
        let mut m = Self::default();
        for b in bsdfs {
            m.add_bsdf(b);
        }
        m
    }

    /// Adds a BSDF, computing the tables it needs from the textures
    /// already present (so add textures first); returns its index.
    pub fn add_bsdf(&mut self, mut b: Bsdf) -> u32 {
        b.prepare(self);
        self.bsdfs.push(b);
        self.bsdfs.len() as u32 - 1
    }

    /// Puts `b` in place of BSDF `index`, with the tables it needs.
    pub fn replace_bsdf(&mut self, index: u32, mut b: Bsdf) {
        b.prepare(self);
        self.bsdfs[index as usize] = b;
        self.drop_stale_tables();
    }

    /// Makes every BSDF's tables again (after a texture changed).
    pub fn prepare_bsdfs(&mut self) {
        self.prepare_each();
        self.drop_stale_tables();
    }

    fn prepare_each(&mut self) {
        for i in 0..self.bsdfs.len() {
            let mut b = self.bsdfs[i];
            b.prepare(self);
            self.bsdfs[i] = b;
        }
    }

    /// Tables of values no BSDF holds any more pile up as a parameter is
    /// edited (a slider, an animation); past twice as many as there are
    /// BSDFs, they are made again from scratch, so that their number
    /// stays bounded and an edit integrates one table on average.
    fn drop_stale_tables(&mut self) {
        if self.rough_transmittance.len() > 2 * self.bsdfs.len() {
            self.rough_transmittance.clear();
            self.prepare_each();
        }
    }
}
