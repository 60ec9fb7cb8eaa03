//! `aov`: arbitrary output variables (Mitsuba 3's `aov` integrator) —
//! depth, position, normals, uv, albedo, indices of the surface each
//! camera ray sees first, as extra EXR layers beside the image of any
//! nested integrators.
//!
//! | parameter  | type       | default | meaning                                              |
//! |------------|------------|---------|------------------------------------------------------|
//! | `aovs`     | string     | (none)  | comma-separated `name:type` pairs (types below)      |
//! | (nested)   | integrator | (none)  | any number, each with a `name`: their RGB(A) becomes layer `name` |
//!
//! | type          | channels          | value at the first hit                                  |
//! |---------------|-------------------|---------------------------------------------------------|
//! | `albedo`      | `name.R,G,B`      | the BSDF's diffuse reflectance, as Mitsuba 3 defines it (see below) |
//! | `depth`       | `name.T`          | distance along the camera ray from where it starts, at the near-clip plane (not view-space z; see below) |
//! | `position`    | `name.X,Y,Z`      | world-space hit point                                   |
//! | `uv`          | `name.U,V`        | surface uv                                              |
//! | `geo_normal`  | `name.X,Y,Z`      | geometric normal (world, unit)                          |
//! | `sh_normal`   | `name.X,Y,Z`      | shading normal (world, unit; interpolated/bump/normal-mapped frame of the hit, before BSDF perturbation) |
//! | `dp_du`, `dp_dv` | `name.X,Y,Z`   | position partials with respect to the uv parameterization |
//! | `prim_index`  | `name.I`          | primitive index within the shape (triangle index)       |
//! | `shape_index` | `name.I`          | 1 + the index of the shape in the scene's load order (0 is left for misses) |
//!
//! ```xml
//! <integrator type="aov">
//!     <string name="aovs" value="dd.y:depth, nn:sh_normal"/>
//!     <integrator type="path" name="my_image"/>
//! </integrator>
//! ```
//!
//! Every value is per camera sample and goes through the film's
//! reconstruction filter like radiance does, so edges average (integer
//! AOVs become fractional there, as in Mitsuba). Rays that miss give 0 in
//! every AOV channel.
//!
//! `depth` is Mitsuba 3's `si.t`: its cameras start rays on the near-clip
//! plane, so depth is the eye distance less `near_clip / cos θ` (θ the
//! angle to the view axis). yubin's rays start at the eye with `t_min` on
//! that plane; the AOV subtracts `t_min` to give the same number.
//!
//! Each nested integrator runs on the same camera ray and sample stream
//! (one after the other) and adds a layer `name` with channels
//! `R`,`G`,`B`,`A` — A is 1 where the camera ray hits a surface or the
//! scene has an environment emitter, else 0 (Mitsuba's `valid` mask of
//! `path`, ignoring `hide_emitters`) — followed by its own extra layers
//! prefixed `name.` (a nested `moment`'s second moment is `name.m2.R`, …).
//! The main `R`,`G`,`B` channels are the first nested integrator's RGB, or
//! 0 when there is none (Mitsuba's image then has only the AOV channels
//! besides a zero RGBA; yubin's main image is RGB and has no alpha).
//!
//! `albedo` is Mitsuba 3's `eval_diffuse_reflectance`: the diffuse colour
//! parameter of `diffuse` (`reflectance`), `plastic` and `roughplastic`
//! (`diffuse_reflectance`), `principled` and `principledthin`
//! (`base_color`), evaluated at the hit (textures included); `twosided`
//! answers for the side the camera sees, `bumpmap` and `normalmap` for the
//! BSDF they wrap. Every other BSDF gets Mitsuba's default, π · f(wo, n):
//! the BSDF's value for light arriving along the shading normal, seen from
//! the camera — an approximation for glossy models (it includes whatever
//! lobe points at the camera) and 0 for purely specular ones.
//!
//! Differences from Mitsuba 3: `duv_dx`, `duv_dy` (yubin's camera rays
//! carry no differentials) and `boundary_test` are not supported and are
//! load errors, as are unknown types, malformed pairs, duplicate names and
//! unnamed nested integrators. `shape_index` labels shapes 1, 2, … in load
//! order; Mitsuba writes its own shape ids (also from 1, but not in file
//! order: the Mitsuba 3.9.1 docs scene numbers its three shapes in
//! reverse), so the labels are not comparable between the two.
//!
//! Reference: Mitsuba 3 documentation, "Arbitrary Output Variables
//! integrator (aov)"; `BSDF::eval_diffuse_reflectance`.

use super::{Integrator, Layer};
use crate::bsdf::{BsdfContext, BsdfModel, Material};
use crate::interaction::SurfaceInteraction;
use crate::material::Materials;
use crate::math::Ray;
use crate::params::{Family, ParamError, Params};
use crate::render::RenderScene;
use crate::sampler::SampleStream;
use crate::Rgb;
use glam::Vec3;

/// What one AOV records about the first hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AovKind {
    /// `albedo`: π · f(wo, n).
    Albedo,
    /// `depth`: distance along the ray.
    Depth,
    /// `position`: world hit point.
    Position,
    /// `uv`: surface parameterization.
    Uv,
    /// `geo_normal`: geometric normal.
    GeoNormal,
    /// `sh_normal`: shading normal.
    ShNormal,
    /// `dp_du`: ∂p/∂u.
    DpDu,
    /// `dp_dv`: ∂p/∂v.
    DpDv,
    /// `prim_index`: primitive index.
    PrimIndex,
    /// `shape_index`: shape index.
    ShapeIndex,
}

impl AovKind {
    /// Every kind with its type string in `aovs`.
    pub const ALL: [(&'static str, AovKind); 10] = [
        ("albedo", AovKind::Albedo),
        ("depth", AovKind::Depth),
        ("position", AovKind::Position),
        ("uv", AovKind::Uv),
        ("geo_normal", AovKind::GeoNormal),
        ("sh_normal", AovKind::ShNormal),
        ("dp_du", AovKind::DpDu),
        ("dp_dv", AovKind::DpDv),
        ("prim_index", AovKind::PrimIndex),
        ("shape_index", AovKind::ShapeIndex),
    ];

    /// The kind named `s` in `aovs`.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.iter().find(|(n, _)| *n == s).map(|&(_, k)| k)
    }

    /// Channel suffixes, as Mitsuba 3 names them.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            AovKind::Albedo => &["R", "G", "B"],
            AovKind::Depth => &["T"],
            AovKind::Uv => &["U", "V"],
            AovKind::Position
            | AovKind::GeoNormal
            | AovKind::ShNormal
            | AovKind::DpDu
            | AovKind::DpDv => &["X", "Y", "Z"],
            AovKind::PrimIndex | AovKind::ShapeIndex => &["I"],
        }
    }
}

/// Parses an `aovs` string (`"dd:depth, nn:sh_normal"`) into names and
/// kinds; the error message says what is wrong with which entry.
pub fn parse_aovs(s: &str) -> Result<Vec<(String, AovKind)>, String> {
    let mut out = Vec::new();
    for entry in s.split(',').map(str::trim).filter(|e| !e.is_empty()) {
        let (name, kind) = match entry.split(':').map(str::trim).collect::<Vec<_>>()[..] {
            [name, kind] if !name.is_empty() && !kind.is_empty() => (name, kind),
            _ => return Err(format!("\"{entry}\" is not a name:type pair")),
        };
        let Some(k) = AovKind::from_name(kind) else {
            let known: Vec<&str> = AovKind::ALL.iter().map(|(n, _)| *n).collect();
            let why = match kind {
                "duv_dx" | "duv_dy" => " (yubin's camera rays carry no ray differentials)",
                "boundary_test" => " (yubin has no boundary test)",
                _ => "",
            };
            return Err(format!(
                "unsupported AOV type \"{kind}\" in \"{entry}\"{why} (known: {})",
                known.join(", ")
            ));
        };
        out.push((name.to_string(), k));
    }
    Ok(out)
}

/// Arbitrary output variables plus any nested integrators.
#[derive(Debug)]
pub struct AovIntegrator {
    /// The AOVs in the order given: layer name and kind.
    pub aovs: Vec<(String, AovKind)>,
    /// Nested integrators with their layer names.
    pub nested: Vec<(String, Box<dyn Integrator>)>,
    /// Channels the nested integrators take (RGBA plus their extras each).
    nested_channels: usize,
    /// Channels the AOVs take.
    aov_channels: usize,
}

impl AovIntegrator {
    /// An AOV integrator from its parts.
    pub fn new(aovs: Vec<(String, AovKind)>, nested: Vec<(String, Box<dyn Integrator>)>) -> Self {
        let nested_channels = nested.iter().map(|(_, i)| i.channel_count() + 1).sum();
        let aov_channels = aovs.iter().map(|(_, k)| k.channels().len()).sum();
        Self {
            aovs,
            nested,
            nested_channels,
            aov_channels,
        }
    }

    /// Builds the integrator and its nested ones from scene parameters.
    pub fn from_params(p: &mut dyn Params) -> Result<Self, ParamError> {
        let spec = p.string_or("aovs", "")?;
        let aovs = parse_aovs(&spec).map_err(|msg| p.param_error("aovs", &msg))?;
        let mut nested = Vec::new();
        loop {
            let Some((name, mut child)) = p.nth_child(Family::Integrator, nested.len())? else {
                break;
            };
            if name.is_empty() {
                return Err(child.error(
                    "an integrator nested in aov needs a name (it names its layer in the output)",
                ));
            }
            let integrator = super::nested_from_params(child.as_mut(), "aov")?;
            nested.push((name, integrator));
        }
        let me = Self::new(aovs, nested);
        let mut seen: Vec<String> = Vec::new();
        for layer in me.extra_layers() {
            if seen.contains(&layer.name) {
                return Err(p.param_error(
                    "aovs",
                    &format!("two output layers are named \"{}\"", layer.name),
                ));
            }
            seen.push(layer.name);
        }
        if me.nested.is_empty() && me.aovs.is_empty() {
            p.warn(
                Some("aovs"),
                "no AOVs and no nested integrator: the image is black",
            );
        }
        Ok(me)
    }

    /// Writes the AOV values for the first hit of `ray` into `out` (which
    /// is zero on entry; misses leave it so).
    fn write_aovs(
        &self,
        scene: &RenderScene,
        ray: &Ray,
        hit: Option<&SurfaceInteraction>,
        out: &mut [f32],
    ) {
        let Some(si) = hit else {
            return;
        };
        let mut o = 0;
        let mut put = |vals: &[f32]| {
            out[o..o + vals.len()].copy_from_slice(vals);
            o += vals.len();
        };
        for &(_, kind) in &self.aovs {
            match kind {
                AovKind::Albedo => put(&albedo(scene, si).to_array()),
                AovKind::Depth => put(&[(si.t - ray.t_min) * ray.d.length()]),
                AovKind::Position => put(&si.p.to_array()),
                AovKind::Uv => put(&si.uv.to_array()),
                AovKind::GeoNormal => put(&si.n.to_array()),
                AovKind::ShNormal => put(&si.sh_frame.n.to_array()),
                AovKind::DpDu => put(&si.dpdu.to_array()),
                AovKind::DpDv => put(&si.dpdv.to_array()),
                AovKind::PrimIndex => put(&[si.prim as f32]),
                AovKind::ShapeIndex => put(&[(si.shape + 1) as f32]),
            }
        }
    }
}

/// The `albedo` AOV at a hit: Mitsuba 3's `eval_diffuse_reflectance` of
/// the surface's BSDF, seen from the camera ray.
pub fn albedo(scene: &RenderScene, si: &SurfaceInteraction) -> Rgb {
    let wo = si.to_local(si.wo);
    diffuse_reflectance(&scene.materials, scene.bsdf_of(si.shape), si, wo, 0)
}

/// Mitsuba 3's `eval_diffuse_reflectance`: the diffuse colour parameter of
/// the models that override it (`diffuse`, `plastic`, `roughplastic`,
/// `principled`, `principledthin`; `twosided`, `bumpmap` and `normalmap`
/// ask the BSDF they wrap), else its default π · f(wo, n), the BSDF's
/// value for light arriving along the shading normal. `depth` bounds the
/// recursion through wrappers.
fn diffuse_reflectance(
    m: &Materials,
    bsdf: &Material,
    si: &SurfaceInteraction,
    wo: Vec3,
    depth: u32,
) -> Rgb {
    const MAX_NESTING: u32 = 16;
    let nested = |id: u32, wo: Vec3| match m.bsdfs.get(id as usize) {
        Some(b) if depth < MAX_NESTING => diffuse_reflectance(m, b, si, wo, depth + 1),
        _ => Rgb::ZERO,
    };
    match bsdf {
        Material::Diffuse(b) => b.reflectance.eval(m, si),
        Material::Plastic(b) => b.diffuse_reflectance.eval(m, si),
        Material::RoughPlastic(b) => b.diffuse_reflectance.eval(m, si),
        Material::Principled(b) => b.common.base_color.eval(m, si),
        Material::PrincipledThin(b) => b.common.base_color.eval(m, si),
        // The side the camera sees, mirrored to that BSDF's front.
        Material::TwoSided(b) if wo.z >= 0.0 => nested(b.front, wo),
        Material::TwoSided(b) => nested(b.back, Vec3::new(wo.x, wo.y, -wo.z)),
        Material::BumpMap(b) => nested(b.nested, wo),
        Material::NormalMap(b) => nested(b.nested, wo),
        other => other.eval(m, &BsdfContext::default(), si, wo, Vec3::Z) * std::f32::consts::PI,
    }
}

impl Integrator for AovIntegrator {
    fn extra_layers(&self) -> Vec<Layer> {
        let mut layers = Vec::new();
        for (name, integrator) in &self.nested {
            layers.push(Layer::new(name.clone(), &["R", "G", "B", "A"]));
            for inner in integrator.extra_layers() {
                layers.push(Layer {
                    name: format!("{name}.{}", inner.name),
                    channels: inner.channels,
                });
            }
        }
        for (name, kind) in &self.aovs {
            layers.push(Layer::new(name.clone(), kind.channels()));
        }
        layers
    }

    fn extra_channel_count(&self) -> usize {
        self.nested_channels + self.aov_channels
    }

    /// Its uv layer reads the hits' uv.
    fn reads_uv(&self) -> bool {
        true
    }

    /// When every nested integrator may (they share the scene's lights).
    fn mis_compensation(&self) -> bool {
        !self.nested.is_empty() && self.nested.iter().all(|(_, i)| i.mis_compensation())
    }

    fn li(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream) -> Rgb {
        match self.nested.first() {
            Some((_, integrator)) => integrator.li(scene, ray, sampler),
            None => Rgb::ZERO,
        }
    }

    fn sample(&self, scene: &RenderScene, ray: &Ray, sampler: &mut SampleStream, out: &mut [f32]) {
        let hit = scene.intersect(ray);
        let alpha = if hit.is_some() || !scene.environment_emitters.is_empty() {
            1.0
        } else {
            0.0
        };
        // Each nested integrator's block: R, G, B, A, then its extras. It
        // writes RGB + extras contiguously; the extras move up one to make
        // room for A (the block has room: it is one wider).
        let mut o = 3;
        for (_, integrator) in &self.nested {
            let n = integrator.channel_count();
            integrator.sample(scene, ray, sampler, &mut out[o..o + n]);
            out.copy_within(o + 3..o + n, o + 4);
            out[o + 3] = alpha;
            o += n + 1;
        }
        if !self.nested.is_empty() {
            out.copy_within(3..6, 0);
        }
        self.write_aovs(scene, ray, hit.as_ref(), &mut out[o..]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::params::MapParams;

    #[test]
    fn parses_mitsuba_aov_lists() {
        let aovs = parse_aovs("nn:sh_normal, position:position,depth.y:depth ,uv:uv").unwrap();
        assert_eq!(
            aovs,
            vec![
                ("nn".to_string(), AovKind::ShNormal),
                ("position".to_string(), AovKind::Position),
                ("depth.y".to_string(), AovKind::Depth),
                ("uv".to_string(), AovKind::Uv),
            ]
        );
        assert!(parse_aovs("").unwrap().is_empty());
        for (name, kind) in AovKind::ALL {
            assert_eq!(
                parse_aovs(&format!("a:{name}")).unwrap(),
                vec![("a".into(), kind)]
            );
        }
    }

    #[test]
    fn rejects_bad_aov_entries() {
        let err = parse_aovs("dd:depht").unwrap_err();
        assert!(err.contains("unsupported AOV type \"depht\""), "{err}");
        assert!(err.contains("sh_normal"), "{err}");
        assert!(parse_aovs("dd").unwrap_err().contains("name:type"));
        assert!(parse_aovs(":depth").is_err());
        assert!(parse_aovs("a:b:c").is_err());
        assert!(parse_aovs("d:duv_dx")
            .unwrap_err()
            .contains("differentials"));
    }

    #[test]
    fn from_params_reports_the_aovs_parameter() {
        let mut p = MapParams::new().string("aovs", "x:nope");
        let err = AovIntegrator::from_params(&mut p).unwrap_err();
        assert!(err.0.contains("parameter \"aovs\""), "{}", err.0);
        let mut p = MapParams::new().string("aovs", "x:depth, x:uv");
        let err = AovIntegrator::from_params(&mut p).unwrap_err();
        assert!(
            err.0.contains("two output layers are named \"x\""),
            "{}",
            err.0
        );
    }

    #[test]
    fn layers_follow_mitsuba_channel_names() {
        let aov = AovIntegrator::new(
            parse_aovs("dd:depth,nn:sh_normal,t:uv,i:prim_index").unwrap(),
            Vec::new(),
        );
        let layers = aov.extra_layers();
        let names: Vec<String> = layers
            .iter()
            .flat_map(|l| l.channels.iter().map(move |c| format!("{}.{c}", l.name)))
            .collect();
        assert_eq!(names, ["dd.T", "nn.X", "nn.Y", "nn.Z", "t.U", "t.V", "i.I"]);
        assert_eq!(aov.channel_count(), 3 + 7);
        assert_eq!(
            aov.extra_channel_count(),
            layers.iter().map(Layer::width).sum::<usize>()
        );
    }

    #[test]
    fn nested_integrators_add_rgba_and_their_layers() {
        let nested: Vec<(String, Box<dyn Integrator>)> = vec![
            (
                "image".into(),
                Box::new(super::super::PathIntegrator::default()),
            ),
            (
                "mom".into(),
                Box::new(super::super::MomentIntegrator {
                    nested: Box::new(super::super::DirectIntegrator::default()),
                }),
            ),
        ];
        let aov = AovIntegrator::new(parse_aovs("dd:depth").unwrap(), nested);
        let layers = aov.extra_layers();
        let summary: Vec<(String, usize)> =
            layers.iter().map(|l| (l.name.clone(), l.width())).collect();
        assert_eq!(
            summary,
            [
                ("image".to_string(), 4),
                ("mom".to_string(), 4),
                ("mom.m2".to_string(), 3),
                ("dd".to_string(), 1)
            ]
        );
        assert_eq!(aov.channel_count(), 3 + 4 + 4 + 3 + 1);
    }
}
