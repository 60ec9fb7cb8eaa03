//! The format-neutral parameter interface through which every plugin builds
//! itself (the role of pbrt-v4's `ParameterDictionary` and Mitsuba 3's
//! `Properties`).
//!
//! A scene front end implements [`Params`] for one object of its scene
//! description: typed getters that mark what they read (so that a parameter
//! nobody read can be reported), nested objects already built into the
//! scene's tables (BSDFs and textures come back as indices), image files
//! loaded into the scene, and errors that carry the object's or the
//! parameter's source location. Each plugin's `from_params` lives in its own
//! file beside its parameter table:
//!
//! ```
//! use yubin_core::params::{ColorKind, ParamError, Params};
//! use yubin_core::texture::Tex;
//! use yubin_core::Rgb;
//!
//! fn reflectance(p: &mut dyn Params) -> Result<Tex, ParamError> {
//!     Ok(p.texture("reflectance", ColorKind::Reflectance)?
//!         .unwrap_or(Tex::Const(Rgb::splat(0.5))))
//! }
//! ```
//!
//! The core itself never reads a file: [`Params::image`] asks the front end
//! to load one and returns its index in [`crate::material::Materials::images`].

use crate::texture::Tex;
use crate::Rgb;
use glam::{DMat4, Vec3};
use std::fmt;

pub mod record;

pub use record::{ParamKind, ParamValue, Parameter, Record, Recorder, Replay};

/// `rgb`, read as parameter `name` of `p` in role `kind`, if it is valid
/// there: finite, and not negative unless the role is unbounded. Front
/// ends and [`crate::Scene::update`] check colours with it alike.
pub fn check_color(
    p: &dyn Params,
    name: &str,
    rgb: Rgb,
    kind: ColorKind,
) -> Result<Rgb, ParamError> {
    let unbounded = kind == ColorKind::Unbounded;
    if !rgb.is_finite() || (!unbounded && rgb.min_element() < 0.0) {
        let allowed = if unbounded {
            "finite"
        } else {
            "finite and not negative"
        };
        return Err(p.param_error(
            name,
            &format!("has an invalid value {rgb} (must be {allowed})"),
        ));
    }
    Ok(rgb)
}

/// A problem with a plugin's parameters. The message already names where
/// (`scene.xml:42: ...`): the front end that made it knows the location.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParamError(pub String);

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ParamError {}

/// How a colour parameter given as a spectrum becomes RGB (Mitsuba 3's RGB
/// variants convert differently by role).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorKind {
    /// A reflectance or transmittance: spectra are weighted by D65 and
    /// clamped to [0, 1]; values must not be negative.
    Reflectance,
    /// An unbounded, non-emissive quantity (index of refraction, absorption
    /// coefficient): a constant spectrum is that value in every channel.
    Unbounded,
    /// Emitted radiance or intensity: a constant spectrum is the sRGB colour
    /// of illuminant E.
    Illuminant,
}

/// Families of plugins nested in another object (besides BSDFs and
/// textures): a sensor's film and sampler, a film's reconstruction
/// filter, an integrator wrapped by another.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// `<film>`.
    Film,
    /// `<sampler>`.
    Sampler,
    /// `<rfilter>`.
    Rfilter,
    /// `<integrator>`.
    Integrator,
    /// `<phase>`: a medium's phase function.
    Phase,
    /// `<volume>`: a medium's spatially varying parameter.
    Volume,
    /// `<sdf>`: a node of an `sdf` shape's distance function.
    Sdf,
    /// `<sensor>`: a `batch` sensor's sensors.
    Sensor,
    /// `<shape>`: a `distant` sensor's target.
    Shape,
}

/// The constructor of `p`'s plugin type in a family's plugin table
/// (`family` names it in messages, e.g. "integrator"); an unknown type is
/// an error listing the known ones, or `known` when given.
pub fn plugin_of<T: Copy>(
    p: &dyn Params,
    family: &str,
    table: &[(&str, T)],
    known: Option<&str>,
) -> Result<T, ParamError> {
    let kind = p.plugin_type();
    table
        .iter()
        .find(|(name, _)| *name == kind)
        .map(|(_, build)| *build)
        .ok_or_else(|| {
            let names: Vec<&str> = table.iter().map(|(name, _)| *name).collect();
            let known = known.map_or_else(|| names.join(", "), str::to_owned);
            p.error(&unknown_type_message(family, &kind, &known))
        })
}

/// What an unknown plugin type is told: the known ones, or for a plugin
/// of Mitsuba 3's spectral or polarized variants, that yubin renders in
/// RGB.
pub fn unknown_type_message(family: &str, kind: &str, known: &str) -> String {
    let not_in_rgb = match kind {
        "specfilm" => Some("spectral plugins (a film of spectral bands)"),
        "polarizer" | "retarder" | "circular" | "pplastic" | "measured_polarized" | "stokes" => {
            Some("polarization plugins")
        }
        _ => None,
    };
    match not_in_rgb {
        Some(why) => format!(
            "{family} \"{kind}\" is one of Mitsuba 3's {why}: yubin renders in RGB, as Mitsuba's *_rgb variants do, which have no \"{kind}\" either"
        ),
        None => format!("unknown {family} type \"{kind}\" (known: {known})"),
    }
}

/// A nested object with the name its parent gives it (empty when unnamed).
pub type NamedChild<'a> = (String, Box<dyn Params + 'a>);

/// One object of a scene description, as a plugin sees it. Getters return
/// `Ok(None)` when the parameter is absent and an error naming its line when
/// it has the wrong type; whatever they return is marked as read.
pub trait Params {
    /// How messages name the object: `bsdf "roughconductor"`.
    fn describe(&self) -> String;
    /// The object's plugin type string (`roughconductor`).
    fn plugin_type(&self) -> String;
    /// The object's one nested object of `family`, if any (more than one
    /// is an error).
    fn child(&mut self, family: Family) -> Result<Option<Box<dyn Params + '_>>, ParamError>;
    /// The object's `index`-th nested object of `family` in the order
    /// written, with the name the parent gives it (empty when unnamed);
    /// `None` past the last. For plugins that take several (`aov`). The
    /// default sees at most the one [`Params::child`] returns.
    fn nth_child(
        &mut self,
        family: Family,
        index: usize,
    ) -> Result<Option<NamedChild<'_>>, ParamError> {
        if index > 0 {
            return Ok(None);
        }
        Ok(self.child(family)?.map(|c| (String::new(), c)))
    }
    /// The nested object of `family` that the parent calls `name`
    /// (`<volume name="albedo" ...>`), if any, marked read. A front end
    /// without nested objects has none.
    fn named_child(
        &mut self,
        _family: Family,
        _name: &str,
    ) -> Result<Option<Box<dyn Params + '_>>, ParamError> {
        Ok(None)
    }
    /// The voxel grid in the file named by string parameter `name`
    /// (Mitsuba's `.vol`), read by the front end (each file once).
    fn grid_file(
        &mut self,
        name: &str,
    ) -> Result<Option<std::sync::Arc<crate::medium::Grid>>, ParamError> {
        Err(self.param_error(name, "this front end reads no volume files"))
    }
    /// An error whose message is `msg` prefixed by the location of parameter
    /// `name` (of the object itself when `name` is `None` or absent).
    fn error_at(&self, name: Option<&str>, msg: &str) -> ParamError;
    /// Whether a parameter or named nested object `name` exists (does not
    /// mark it read).
    fn has(&self, name: &str) -> bool;
    /// A float (an integer is accepted).
    fn float(&mut self, name: &str) -> Result<Option<f32>, ParamError>;
    /// An integer.
    fn integer(&mut self, name: &str) -> Result<Option<i64>, ParamError>;
    /// A boolean.
    fn boolean(&mut self, name: &str) -> Result<Option<bool>, ParamError>;
    /// A string.
    fn string(&mut self, name: &str) -> Result<Option<String>, ParamError>;
    /// A point (a vector is accepted).
    fn point(&mut self, name: &str) -> Result<Option<Vec3>, ParamError>;
    /// A vector (a point is accepted).
    fn vector(&mut self, name: &str) -> Result<Option<Vec3>, ParamError>;
    /// A transform, composed in f64.
    fn transform(&mut self, name: &str) -> Result<Option<DMat4>, ParamError>;
    /// The world-space target of the `<lookat>` in transform `name`, if
    /// the front end knows one (cameras focus there by default).
    fn look_at_target(&mut self, _name: &str) -> Option<Vec3> {
        None
    }
    /// A constant colour (rgb, spectrum, or a float for grey); a texture here
    /// is an error.
    fn color(&mut self, name: &str, kind: ColorKind) -> Result<Option<Rgb>, ParamError>;
    /// A texturable parameter: a constant colour or float, or a nested or
    /// referenced texture (built into the scene's texture table).
    fn texture(&mut self, name: &str, kind: ColorKind) -> Result<Option<Tex>, ParamError>;
    /// Every nested texture that is not a named parameter read otherwise
    /// (e.g. `bumpmap`'s height, whatever its name), built, in order. A
    /// front end without nested objects has none.
    fn nested_textures(&mut self) -> Result<Vec<Tex>, ParamError> {
        Ok(Vec::new())
    }
    /// Every nested BSDF, built into the scene's BSDF table, in the order
    /// written: its index and (a copy of) what was built.
    fn bsdfs(&mut self) -> Result<Vec<(u32, crate::bsdf::Material)>, ParamError>;
    /// Loads the image file named by string parameter `name` into the
    /// scene's image table (each file once) and returns its index.
    fn image(&mut self, name: &str) -> Result<Option<u32>, ParamError>;
    /// The triangle mesh in the file a mesh plugin (`obj`, `ply`,
    /// `serialized`) names: the front end reads `filename` and the
    /// format's own parameters (`flip_tex_coords`, `shape_index`).
    fn mesh_file(&mut self) -> Result<crate::shape::MeshData, ParamError> {
        Err(self.error("this front end reads no mesh files"))
    }
    /// The bytes of the file named by string parameter `name` (a
    /// `measured` BSDF's tensor file), read by the front end.
    fn file_bytes(&mut self, name: &str) -> Result<Option<Vec<u8>>, ParamError> {
        Err(self.param_error(name, "this front end reads no files"))
    }
    /// The first element of the PLY file named by string parameter `name`,
    /// as a table of float properties (`ellipsoids`' Gaussians).
    fn ply_table(&mut self, name: &str) -> Result<Option<crate::shape::PropertyTable>, ParamError> {
        Err(self.param_error(name, "this front end reads no PLY files"))
    }
    /// The index of mesh attribute `attribute` (`vertex_color`, …) in the
    /// scene's attribute-name table, added if new. A front end without a
    /// scene has none.
    fn attribute_index(&mut self, attribute: &str) -> Result<u32, ParamError> {
        Err(self.error(&format!("no scene to hold mesh attribute \"{attribute}\"")))
    }

    /// Marks parameter `name` as read without using it.
    fn mark_ignored(&mut self, name: &str);
    /// A warning for the user, located at parameter `name` (or the object).
    fn warn(&mut self, name: Option<&str>, msg: &str);

    /// An error at the object's declaration: `bsdf "x": msg`.
    fn error(&self, msg: &str) -> ParamError {
        self.error_at(None, &format!("{}: {msg}", self.describe()))
    }
    /// An error at parameter `name`: `parameter "name" of bsdf "x": msg`.
    fn param_error(&self, name: &str, msg: &str) -> ParamError {
        self.error_at(
            Some(name),
            &format!("parameter \"{name}\" of {}: {msg}", self.describe()),
        )
    }
    /// [`Params::float`] with a default.
    fn float_or(&mut self, name: &str, default: f32) -> Result<f32, ParamError> {
        Ok(self.float(name)?.unwrap_or(default))
    }
    /// [`Params::integer`] with a default.
    fn integer_or(&mut self, name: &str, default: i64) -> Result<i64, ParamError> {
        Ok(self.integer(name)?.unwrap_or(default))
    }
    /// [`Params::boolean`] with a default.
    fn boolean_or(&mut self, name: &str, default: bool) -> Result<bool, ParamError> {
        Ok(self.boolean(name)?.unwrap_or(default))
    }
    /// [`Params::string`] with a default.
    fn string_or(&mut self, name: &str, default: &str) -> Result<String, ParamError> {
        Ok(self.string(name)?.unwrap_or_else(|| default.to_string()))
    }
    /// [`Params::color`] with a default.
    fn color_or(&mut self, name: &str, kind: ColorKind, default: Rgb) -> Result<Rgb, ParamError> {
        Ok(self.color(name, kind)?.unwrap_or(default))
    }
    /// [`Params::texture`] with a constant default.
    fn texture_or(&mut self, name: &str, kind: ColorKind, default: Rgb) -> Result<Tex, ParamError> {
        Ok(self.texture(name, kind)?.unwrap_or(Tex::Const(default)))
    }
    /// Transform `name` as an invertible [`crate::math::Transform`]
    /// (identity when absent).
    fn transform_or_identity(&mut self, name: &str) -> Result<crate::math::Transform, ParamError> {
        let m = self.transform(name)?.unwrap_or(DMat4::IDENTITY);
        crate::math::Transform::from_mat4(m.as_mat4()).ok_or_else(|| {
            self.error_at(
                Some(name),
                &format!("\"{name}\" of {} is not invertible", self.describe()),
            )
        })
    }
    /// A float that must be positive (NaN is rejected too).
    fn positive_float_or(&mut self, name: &str, default: f32) -> Result<f32, ParamError> {
        let v = self.float_or(name, default)?;
        if v > 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(self.param_error(name, &format!("must be positive, not {v}")))
        }
    }

    /// A float that must be finite and 0 or more (a scale factor).
    fn non_negative_float_or(&mut self, name: &str, default: f32) -> Result<f32, ParamError> {
        let v = self.float_or(name, default)?;
        if v >= 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(self.param_error(name, &format!("must be finite and ≥ 0, not {v}")))
        }
    }

    /// A positive integer, `default` when absent.
    fn positive_integer_or(&mut self, name: &str, default: i64) -> Result<u32, ParamError> {
        let v = self.integer_or(name, default)?;
        u32::try_from(v)
            .ok()
            .filter(|&v| v > 0)
            .ok_or_else(|| self.param_error(name, &format!("must be a positive integer, not {v}")))
    }

    /// Marks parameters that yubin accepts but does not use as read, with
    /// a warning for each one present saying `why`.
    fn warn_ignored(&mut self, names: &[&str], why: &str) {
        for name in names {
            if self.has(name) {
                self.mark_ignored(name);
                let msg = format!(
                    "ignoring parameter \"{name}\" of {} ({why})",
                    self.describe()
                );
                self.warn(Some(name), &msg);
            }
        }
    }

    /// One of `choices` (the first is the default).
    fn choice(&mut self, name: &str, choices: &[&str]) -> Result<usize, ParamError> {
        let Some(v) = self.string(name)? else {
            return Ok(0);
        };
        choices.iter().position(|c| *c == v).ok_or_else(|| {
            self.param_error(
                name,
                &format!("must be one of {}, not \"{v}\"", choices.join(", ")),
            )
        })
    }
}
