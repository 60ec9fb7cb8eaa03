//! `mesh_attribute`: the value of a named mesh attribute at the hit: a
//! per-vertex attribute (`vertex_<name>`) interpolated with the hit's
//! barycentric coordinates, or a per-face one (`face_<name>`), constant over
//! each triangle. PLY files carry them (vertex and face colours), as in
//! Mitsuba 3.
//!
//! | parameter | type   | default  | meaning                                            |
//! |-----------|--------|----------|----------------------------------------------------|
//! | `name`    | string | required | the attribute: `vertex_…` or `face_…` (e.g. `vertex_color`) |
//! | `scale`   | float  | 1        | multiplies the value                               |
//!
//! ```xml
//! <shape type="ply">
//!     <string name="filename" value="meshes/painted.ply"/>
//!     <bsdf type="diffuse">
//!         <texture type="mesh_attribute" name="reflectance">
//!             <string name="name" value="vertex_color"/>
//!         </texture>
//!     </bsdf>
//! </shape>
//! ```
//!
//! An attribute has one or three channels: one is grey for
//! [`TextureModel::eval`]; [`TextureModel::eval_1`] of three is their
//! luminance (Mitsuba refuses `eval_1` of a colour attribute; yubin follows
//! the texture contract instead). The derivative is zero, and the mean is
//! ½: Mitsuba has no mean for this texture and refuses `plastic` with it.
//!
//! **Where the values live.**
//!
//! A texture is shared by every shape whose BSDF uses it, and each mesh has
//! its own attributes, so the texture is resolved per hit:
//!
//! - the scene keeps one attribute-name table ([`MeshAttributes::names`]);
//!   the texture holds the index of its name there, found when it is built;
//! - each mesh that has attributes owns a *set*: a range of
//!   [`AttributeSlot`]s (name index, per vertex or per face, channel count,
//!   offset of its values in [`MeshAttributes::data`]). Loaders attach the
//!   attributes to the [`crate::shape::TriangleMesh`]; adding the mesh to
//!   the scene moves them into [`crate::material::Materials::attributes`],
//!   because textures see only the material tables;
//! - a triangle hit carries its mesh's set, the triangle's vertex indices
//!   and the barycentrics ([`SurfaceInteraction::attributes`],
//!   [`SurfaceInteraction::vertices`], [`SurfaceInteraction::bary`]);
//!   evaluation searches the set's few slots for the name and reads three
//!   (or one) values: no allocation.
//!
//! A shape whose BSDF reads an attribute its mesh lacks (or that is not a
//! mesh) is an error when the scene is loaded (Mitsuba fails at render
//! time: `Invalid attribute requested`); at evaluation a missing attribute
//! reads as zero.
//!
//! **PLY properties** (Mitsuba 3.9.1, checked).
//!
//! Every vertex or face property other than positions, normals, texture
//! coordinates and indices becomes an attribute: `r g b [a]` and
//! `red green blue [alpha]` become `color`; `<name>_0 … <name>_k` become
//! `<name>`; one or three channels are kept (`color` may have four, which
//! the texture refuses); others, and names without a `_<digit>` suffix, are
//! skipped. Values: floats as they are, `uchar` as they are (0–255, which
//! Mitsuba warns about), other integer types divided by their largest value
//! and decoded from sRGB.

use super::TextureModel;
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::params::{ParamError, Params};
use crate::spectrum::luminance;
use crate::Rgb;
use glam::Vec2;

/// [`SurfaceInteraction::attributes`] of a hit without mesh attributes.
pub const NO_ATTRIBUTES: u32 = u32::MAX;

/// A named attribute as a loader reads it, before the scene owns it.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedAttribute {
    /// Full name: `vertex_<name>` or `face_<name>`.
    pub name: String,
    /// Values per element (1 or 3; `color` may have 4).
    pub channels: u8,
    /// `channels` values per vertex (or per triangle), interleaved.
    pub values: Vec<f32>,
}

impl NamedAttribute {
    /// Whether it has one value per triangle (a `face_` attribute).
    pub fn per_face(&self) -> bool {
        self.name.starts_with("face_")
    }
}

/// One attribute of one mesh in the scene's table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AttributeSlot {
    /// Index in [`MeshAttributes::names`].
    pub name: u32,
    /// One value per triangle rather than per vertex.
    pub per_face: bool,
    /// Values per element.
    pub channels: u8,
    /// Where its values start in [`MeshAttributes::data`].
    pub offset: usize,
}

/// The scene's mesh attributes: a name table shared by textures and meshes,
/// and one set of slots per mesh that has attributes (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshAttributes {
    /// Attribute names (`vertex_color`, …), each once.
    pub names: Vec<String>,
    /// Per set: the range of its slots in `slots`.
    pub sets: Vec<(u32, u32)>,
    /// Every set's slots.
    pub slots: Vec<AttributeSlot>,
    /// Every attribute's values.
    pub data: Vec<f32>,
}

impl MeshAttributes {
    /// No attributes.
    pub const EMPTY: MeshAttributes = MeshAttributes {
        names: Vec::new(),
        sets: Vec::new(),
        slots: Vec::new(),
        data: Vec::new(),
    };

    /// The index of `name`, added if new.
    pub fn intern(&mut self, name: &str) -> u32 {
        match self.names.iter().position(|n| n == name) {
            Some(i) => i as u32,
            None => {
                self.names.push(name.to_string());
                self.names.len() as u32 - 1
            }
        }
    }

    /// Takes over one mesh's attributes; returns the index of its set.
    pub fn add_set(&mut self, attributes: Vec<NamedAttribute>) -> u32 {
        let first = self.slots.len() as u32;
        for a in attributes {
            let name = self.intern(&a.name);
            self.slots.push(AttributeSlot {
                name,
                per_face: a.per_face(),
                channels: a.channels,
                offset: self.data.len(),
            });
            self.data.extend_from_slice(&a.values);
        }
        self.sets.push((first, self.slots.len() as u32));
        self.sets.len() as u32 - 1
    }

    /// Attribute `name` of set `set`, if it has one.
    #[inline]
    pub fn find(&self, set: u32, name: u32) -> Option<&AttributeSlot> {
        let &(first, end) = self.sets.get(set as usize)?;
        self.slots[first as usize..end as usize]
            .iter()
            .find(|s| s.name == name)
    }

    /// Attribute `name` at `si` and its channel count (1 or 3), if the hit
    /// mesh has it with one or three channels.
    #[inline]
    pub fn eval(&self, name: u32, si: &SurfaceInteraction) -> Option<(Rgb, u8)> {
        let slot = self.find(si.attributes, name)?;
        let c = slot.channels as usize;
        if c != 1 && c != 3 {
            return None;
        }
        let at = |element: u32| -> Rgb {
            let i = slot.offset + element as usize * c;
            match self.data.get(i..i + c) {
                Some(&[v]) => Rgb::splat(v),
                Some(&[r, g, b]) => Rgb::new(r, g, b),
                _ => Rgb::ZERO,
            }
        };
        let value = if slot.per_face {
            at(si.prim)
        } else {
            let Vec2 { x: b1, y: b2 } = si.bary;
            let [v0, v1, v2] = si.vertices;
            at(v0) * (1.0 - b1 - b2) + at(v1) * b1 + at(v2) * b2
        };
        Some((value, slot.channels))
    }
}

/// A mesh attribute as a texture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshAttribute {
    /// Index of the attribute's name in [`MeshAttributes::names`].
    pub name: u32,
    /// Multiplies the value.
    pub scale: f32,
}

impl MeshAttribute {
    /// Builds the texture from its scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let name = p
            .string("name")?
            .ok_or_else(|| p.error("needs the parameter \"name\""))?;
        if !(name.starts_with("vertex_") || name.starts_with("face_")) {
            return Err(p.param_error(
                "name",
                &format!("must start with \"vertex_\" or \"face_\", not \"{name}\""),
            ));
        }
        let scale = p.float_or("scale", 1.0)?;
        if !scale.is_finite() {
            return Err(p.param_error("scale", &format!("must be finite, not {scale}")));
        }
        Ok(Self {
            name: p.attribute_index(&name)?,
            scale,
        })
    }
}

impl TextureModel for MeshAttribute {
    #[inline]
    fn eval(&self, m: &Materials, si: &SurfaceInteraction) -> Rgb {
        m.attributes
            .eval(self.name, si)
            .map_or(Rgb::ZERO, |(v, _)| v * self.scale)
    }

    #[inline]
    fn eval_1(&self, m: &Materials, si: &SurfaceInteraction) -> f32 {
        match m.attributes.eval(self.name, si) {
            Some((v, 1)) => v.x * self.scale,
            Some((v, _)) => luminance(v) * self.scale,
            None => 0.0,
        }
    }

    fn eval_1_grad(&self, m: &Materials, si: &SurfaceInteraction) -> (f32, Vec2) {
        (self.eval_1(m, si), Vec2::ZERO)
    }

    fn mean(&self, _m: &Materials) -> f32 {
        0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::tests::flat_si;

    /// One triangle with vertex colours red, green, blue, a one-channel
    /// vertex weight, and face colours for two triangles.
    fn materials() -> (Materials, MeshAttribute, MeshAttribute, MeshAttribute) {
        let mut m = Materials::default();
        let color = m.attributes.intern("vertex_color");
        let weight = m.attributes.intern("vertex_weight");
        let face = m.attributes.intern("face_color");
        m.attributes.add_set(vec![NamedAttribute {
            name: "vertex_nothing".into(),
            channels: 1,
            values: vec![9.0; 4],
        }]);
        let set = m.attributes.add_set(vec![
            NamedAttribute {
                name: "vertex_color".into(),
                channels: 3,
                values: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            },
            NamedAttribute {
                name: "vertex_weight".into(),
                channels: 1,
                values: vec![0.0, 0.2, 0.4, 0.6],
            },
            NamedAttribute {
                name: "face_color".into(),
                channels: 3,
                values: vec![0.1, 0.2, 0.3, 0.7, 0.8, 0.9],
            },
        ]);
        assert_eq!(set, 1);
        let tex = |name| MeshAttribute { name, scale: 1.0 };
        (m, tex(color), tex(weight), tex(face))
    }

    /// A hit on triangle `prim` (vertices 1, 2, 3) of set 1.
    fn hit(prim: u32, bary: Vec2) -> SurfaceInteraction {
        SurfaceInteraction {
            prim,
            bary,
            vertices: [1, 2, 3],
            attributes: 1,
            tangent: glam::Vec4::ZERO,
            ..flat_si()
        }
    }

    #[test]
    fn vertex_colours_interpolate_barycentrically() {
        let (m, color, weight, _) = materials();
        let centroid = hit(0, Vec2::splat(1.0 / 3.0));
        let c = color.eval(&m, &centroid);
        assert!(
            (c - Rgb::splat(1.0 / 3.0)).abs().max_element() < 1e-6,
            "{c}"
        );
        // At a vertex: that vertex's colour.
        assert_eq!(color.eval(&m, &hit(0, Vec2::new(0.0, 1.0))), Rgb::Z);
        let c = color.eval(&m, &hit(0, Vec2::new(0.25, 0.5)));
        assert!((c - Rgb::new(0.25, 0.25, 0.5)).abs().max_element() < 1e-6);
        // One channel: grey, and eval_1 is the value itself.
        let w = weight.eval_1(&m, &hit(0, Vec2::new(0.25, 0.5)));
        assert!((w - (0.2 * 0.25 + 0.4 * 0.25 + 0.6 * 0.5)).abs() < 1e-6);
        assert_eq!(
            weight.eval(&m, &centroid),
            Rgb::splat(weight.eval_1(&m, &centroid))
        );
        // Three channels: eval_1 is the luminance.
        let l = color.eval_1(&m, &centroid);
        assert!((l - luminance(Rgb::splat(1.0 / 3.0))).abs() < 1e-6);
        let scaled = MeshAttribute {
            scale: 2.0,
            ..color
        };
        assert!(
            (scaled.eval(&m, &centroid) - Rgb::splat(2.0 / 3.0))
                .abs()
                .max_element()
                < 1e-6
        );
    }

    #[test]
    fn face_attributes_are_constant_per_triangle() {
        let (m, _, _, face) = materials();
        for bary in [Vec2::ZERO, Vec2::new(0.3, 0.6), Vec2::X] {
            assert_eq!(face.eval(&m, &hit(0, bary)), Rgb::new(0.1, 0.2, 0.3));
            assert_eq!(face.eval(&m, &hit(1, bary)), Rgb::new(0.7, 0.8, 0.9));
        }
    }

    #[test]
    fn missing_attribute_reads_zero() {
        let (mut m, color, ..) = materials();
        // Set 0 lacks vertex_color; a non-mesh hit has no set at all.
        let other = SurfaceInteraction {
            attributes: 0,
            ..hit(0, Vec2::splat(0.3))
        };
        assert_eq!(color.eval(&m, &other), Rgb::ZERO);
        assert_eq!(color.eval_1(&m, &flat_si()), 0.0);
        let unknown = MeshAttribute {
            name: m.attributes.intern("vertex_unknown"),
            scale: 1.0,
        };
        assert_eq!(unknown.eval(&m, &hit(0, Vec2::splat(0.3))), Rgb::ZERO);
        assert_eq!(m.attributes.intern("vertex_color"), color.name);
    }
}
