//! [`yubin_core::params::Params`] for one object of a scene description:
//! the bridge through which every core plugin's `from_params` reads its
//! parameters. Reads mark parameters used (the builder reports the rest),
//! nested BSDFs and textures are built into the scene under construction
//! (each shared object once), image files are loaded once per path, and
//! errors carry `file:line`.

use crate::build::Builder;
use crate::desc::{Category, Object, Spectrum, Value};
use crate::error::SceneError;
use glam::{DMat4, Vec3};
use yubin_core::bsdf::Material;
use yubin_core::params::{ColorKind, Family, NamedChild, ParamError, Params};
use yubin_core::spectrum::{constant_spectrum_to_rgb, spectrum_to_rgb, Rgb};
use yubin_core::texture::Tex;

/// One object seen through [`Params`], with the builder that builds what it
/// refers to.
pub(crate) struct ObjParams<'o, 'b, 'd> {
    pub obj: &'o Object,
    pub b: &'b mut Builder<'d>,
}

/// A scene error as a parameter error (its message already says where).
pub(crate) fn to_param(e: SceneError) -> ParamError {
    ParamError(e.to_string())
}

/// A colour property's value as RGB for its role.
fn value_to_rgb(value: &Value, kind: ColorKind) -> Option<Rgb> {
    Some(match value {
        Value::Rgb(c) => Rgb::from_array(*c),
        Value::Float(v) => Rgb::splat(*v as f32),
        Value::Integer(v) => Rgb::splat(*v as f32),
        Value::Spectrum(Spectrum::Constant(v)) => constant_spectrum_to_rgb(*v, kind),
        Value::Spectrum(Spectrum::Sampled(s)) => spectrum_to_rgb(s, kind),
        _ => return None,
    })
}

/// The description category of a nested-object family.
fn category_of(family: Family) -> Category {
    match family {
        Family::Film => Category::Film,
        Family::Sampler => Category::Sampler,
        Family::Rfilter => Category::Rfilter,
        Family::Integrator => Category::Integrator,
        Family::Phase => Category::Phase,
        Family::Volume => Category::Volume,
        Family::Sdf => Category::Sdf,
        Family::Sensor => Category::Sensor,
        Family::Shape => Category::Shape,
    }
}

impl ObjParams<'_, '_, '_> {
    fn check_color(&self, name: &str, rgb: Rgb, kind: ColorKind) -> Result<Rgb, ParamError> {
        yubin_core::params::check_color(self, name, rgb, kind)
    }

    /// The nested object called `name`, if there is one.
    fn named_object(&self, name: &str) -> Option<std::rc::Rc<Object>> {
        self.obj.child(name).map(|c| c.object.clone())
    }
}

impl Params for ObjParams<'_, '_, '_> {
    fn describe(&self) -> String {
        self.obj.describe()
    }

    fn plugin_type(&self) -> String {
        self.obj.plugin_type.clone()
    }

    fn child(&mut self, family: Family) -> Result<Option<Box<dyn Params + '_>>, ParamError> {
        let obj = self.obj;
        let child = obj.single_child(category_of(family)).map_err(to_param)?;
        Ok(child.map(|c| {
            Box::new(ObjParams {
                obj: &c.object,
                b: &mut *self.b,
            }) as Box<dyn Params + '_>
        }))
    }

    fn nth_child(
        &mut self,
        family: Family,
        index: usize,
    ) -> Result<Option<NamedChild<'_>>, ParamError> {
        let obj = self.obj;
        let Some(c) = obj.children_of(category_of(family)).nth(index) else {
            return Ok(None);
        };
        let name = c.name.clone().unwrap_or_default();
        Ok(Some((
            name,
            Box::new(ObjParams {
                obj: &c.object,
                b: &mut *self.b,
            }) as Box<dyn Params + '_>,
        )))
    }

    fn named_child(
        &mut self,
        family: Family,
        name: &str,
    ) -> Result<Option<Box<dyn Params + '_>>, ParamError> {
        let obj = self.obj;
        match obj.find_named_child(name) {
            Some(c) if c.category == category_of(family) => {
                let child = obj.child(name).expect("found above");
                Ok(Some(Box::new(ObjParams {
                    obj: &child.object,
                    b: &mut *self.b,
                }) as Box<dyn Params + '_>))
            }
            _ => Ok(None),
        }
    }

    fn grid_file(
        &mut self,
        name: &str,
    ) -> Result<Option<std::sync::Arc<yubin_core::medium::Grid>>, ParamError> {
        let Some(file) = self.obj.string(name).map_err(to_param)? else {
            return Ok(None);
        };
        let file = file.to_owned();
        let loc = self.obj.loc_of(name).clone();
        self.b.grid(&file, &loc).map(Some).map_err(to_param)
    }

    fn error_at(&self, name: Option<&str>, msg: &str) -> ParamError {
        let loc = match name {
            Some(n) => self.obj.loc_of(n),
            None => &self.obj.loc,
        };
        ParamError(format!("{loc}: {msg}"))
    }

    fn has(&self, name: &str) -> bool {
        self.obj.has(name)
    }

    fn float(&mut self, name: &str) -> Result<Option<f32>, ParamError> {
        self.obj.float(name).map_err(to_param)
    }

    fn integer(&mut self, name: &str) -> Result<Option<i64>, ParamError> {
        self.obj.integer(name).map_err(to_param)
    }

    fn boolean(&mut self, name: &str) -> Result<Option<bool>, ParamError> {
        self.obj.boolean(name).map_err(to_param)
    }

    fn string(&mut self, name: &str) -> Result<Option<String>, ParamError> {
        Ok(self.obj.string(name).map_err(to_param)?.map(str::to_owned))
    }

    fn point(&mut self, name: &str) -> Result<Option<Vec3>, ParamError> {
        self.obj.point(name).map_err(to_param)
    }

    fn vector(&mut self, name: &str) -> Result<Option<Vec3>, ParamError> {
        self.obj.vector(name).map_err(to_param)
    }

    fn transform(&mut self, name: &str) -> Result<Option<DMat4>, ParamError> {
        self.obj.transform_opt(name).map_err(to_param)
    }

    fn look_at_target(&mut self, name: &str) -> Option<Vec3> {
        self.obj.look_at_target(name)
    }

    fn color(&mut self, name: &str, kind: ColorKind) -> Result<Option<Rgb>, ParamError> {
        if let Some(child) = self.named_object(name) {
            return match child.category {
                Category::Spectrum => {
                    let rgb = self.b.spectrum_object(&child, kind)?;
                    self.check_color(name, rgb, kind).map(Some)
                }
                other => Err(self.param_error(
                    name,
                    &format!("must be a colour or a number, not a {other}"),
                )),
            };
        }
        let Some(value) = self.obj.rgb_or_spectrum(name).map_err(to_param)? else {
            return Ok(None);
        };
        let rgb =
            value_to_rgb(value, kind).ok_or_else(|| self.param_error(name, "expected a colour"))?;
        self.check_color(name, rgb, kind).map(Some)
    }

    fn texture(&mut self, name: &str, kind: ColorKind) -> Result<Option<Tex>, ParamError> {
        if let Some(child) = self.obj.find_named_child(name) {
            if child.category == Category::Texture {
                self.obj.child(name);
                return self.b.texture(&child, name).map(|t| Some(Tex::Texture(t)));
            }
        }
        Ok(self.color(name, kind)?.map(Tex::Const))
    }

    fn nested_textures(&mut self) -> Result<Vec<Tex>, ParamError> {
        let kids: Vec<_> = self
            .obj
            .children_of(Category::Texture)
            .map(|c| c.object.clone())
            .collect();
        kids.iter()
            .map(|k| self.b.texture(k, "texture").map(Tex::Texture))
            .collect()
    }

    fn bsdfs(&mut self) -> Result<Vec<(u32, Material)>, ParamError> {
        let kids: Vec<_> = self
            .obj
            .children_of(Category::Bsdf)
            .map(|c| c.object.clone())
            .collect();
        kids.iter()
            .map(|k| {
                let id = self.b.bsdf(k).map_err(to_param)?;
                Ok((id, self.b.built_bsdf(id)))
            })
            .collect()
    }

    fn image(&mut self, name: &str) -> Result<Option<u32>, ParamError> {
        let Some(file) = self.obj.string(name).map_err(to_param)? else {
            return Ok(None);
        };
        let file = file.to_owned();
        let loc = self.obj.loc_of(name).clone();
        self.b.image(&file, &loc).map(Some).map_err(to_param)
    }

    fn attribute_index(&mut self, attribute: &str) -> Result<u32, ParamError> {
        Ok(self.b.attribute_index(attribute))
    }

    fn mesh_file(&mut self) -> Result<yubin_core::shape::MeshData, ParamError> {
        self.b.mesh_file(self.obj).map_err(to_param)
    }

    fn file_bytes(&mut self, name: &str) -> Result<Option<Vec<u8>>, ParamError> {
        let Some(file) = self.obj.string(name).map_err(to_param)? else {
            return Ok(None);
        };
        let loc = self.obj.loc_of(name);
        let path = (self.b.desc.resolve_file(file, loc)).map_err(to_param)?;
        std::fs::read(&path)
            .map(Some)
            .map_err(|e| ParamError(format!("{loc}: cannot read {}: {e}", path.display())))
    }

    fn ply_table(
        &mut self,
        name: &str,
    ) -> Result<Option<yubin_core::shape::PropertyTable>, ParamError> {
        let Some(file) = self.obj.string(name).map_err(to_param)? else {
            return Ok(None);
        };
        let path = (self.b.desc.resolve_file(file, self.obj.loc_of(name))).map_err(to_param)?;
        let loc = self.obj.loc_of(name);
        crate::mesh::ply::load_ply_table(&path)
            .map(Some)
            .map_err(|e| ParamError(format!("{loc}: {e}")))
    }

    fn mark_ignored(&mut self, name: &str) {
        self.obj.mark_ignored(name);
    }

    fn warn(&mut self, name: Option<&str>, msg: &str) {
        let loc = match name {
            Some(n) => self.obj.loc_of(n),
            None => &self.obj.loc,
        };
        self.b.warnings.push(format!("{loc}: {msg}"));
    }
}
