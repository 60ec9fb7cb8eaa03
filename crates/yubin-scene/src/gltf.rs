//! `gltf`: glTF 2.0 scenes (`.gltf` with its buffers and images, or
//! `.glb`): `yubin render model.glb`, and `<shape type="gltf">` to place a
//! model in a Mitsuba XML scene.
//!
//! | parameter  | type      | default  | meaning |
//! |------------|-----------|----------|---------|
//! | `filename` | string    | —        | the `.gltf` or `.glb` file |
//! | `to_world` | transform | identity | placed before the model's own node transforms |
//!
//! ```xml
//! <shape type="gltf">
//!     <string name="filename" value="WaterBottle.glb"/>
//!     <transform name="to_world"><scale value="10"/></transform>
//! </shape>
//! ```
//!
//! What is read, from the file's default scene (else its first):
//! - **Nodes**: the hierarchy with TRS or matrices. A mesh that several
//!   nodes use is built once in a shape group and placed by instances
//!   (inside a `shapegroup`, where instances cannot nest, it is copied).
//! - **Meshes**: triangle primitives (other modes are skipped with a
//!   warning): positions, normals, `TEXCOORD_0`, indices (glTF's uv has
//!   its origin at the image's top left, as Mitsuba's bitmaps do, so it
//!   is used as it is), `TANGENT` (MikkTSpace by the spec; computed where
//!   a normal map needs tangents and the file has none), `COLOR_0` (times
//!   the base colour factor, as the `vertex_color` mesh attribute the
//!   base colour reads; under a base colour texture it is ignored, with a
//!   warning).
//! - **Materials** (metallic-roughness) become `principled`: base colour
//!   (factor × sRGB texture), metallic and roughness (factors × the
//!   texture's blue and green channels), specular 0.5 (F0 = 0.04, glTF's
//!   dielectric). Mitsuba's principled is Burley's: its diffuse has the
//!   retro-reflection and Fresnel shape of the Disney BRDF where glTF's
//!   reference BRDF is Lambertian, and its sheen, clearcoat and
//!   transmission stay off. Both use α = roughness² with GGX, so
//!   highlights agree; diffuse surfaces are slightly brighter at grazing
//!   angles than a rasterizer shows them. A normal texture becomes a
//!   `normalmap` (MikkTSpace, its `scale` applied to x and y), emission
//!   (factor × sRGB texture × `KHR_materials_emissive_strength`) an area
//!   light with that radiance, `doubleSided` a `twosided`, alpha `MASK` a
//!   `mask` of opacity 0 or 1 (alpha against the cutoff, per texel) and
//!   `BLEND` a `mask` of opacity alpha (stochastic transparency). The
//!   sampler's magnification filter (nearest or linear) and its S and T
//!   wrap modes are used (no mipmaps: yubin's bitmaps have none). Images
//!   may be 8- or 16-bit, grey, grey and alpha, RGB or RGBA. Occlusion
//!   textures are for rasterizers (light the renderer computes itself)
//!   and are ignored. A primitive without material gets glTF's default
//!   (white, metallic 1, roughness 1).
//! - **Lights** (`KHR_lights_punctual`): `point` (candela become radiant
//!   intensity, W/sr, at 683 lm/W, the conversion Blender's exporter
//!   applies to its watts, so a Blender light keeps its power), `spot`
//!   (the same, with its outer and inner cone angles as `cutoff_angle`
//!   and `beam_width`), `directional` (lux become irradiance, W/m², at
//!   683 lm/W). `range` is ignored (physical falloff only).
//! - **Cameras** (only for a `.gltf`/`.glb` rendered on its own): the
//!   first camera the scene's nodes use, perspective (`yfov`) or
//!   orthographic (`xmag`, `ymag`); glTF cameras look along −z with +y up,
//!   Mitsuba's along +z with +x to the left, so the node's matrix is
//!   turned 180° about y. Without one, a 40° camera looks at the model's
//!   bounds from +z.
//!
//! Rendering a glTF file on its own, what the file lacks comes from
//! options: the resolution (default 1024 wide, the camera's aspect ratio
//! or 4:3), samples per pixel (default 64), an environment map (`--env`;
//! without it and without lights, a white constant environment).
//!
//! References: the glTF 2.0 specification (Khronos, 2021), appendix B
//! (the metallic-roughness BRDF); `KHR_lights_punctual`,
//! `KHR_texture_transform`, `KHR_materials_emissive_strength`.

use crate::build::Builder;
use crate::desc::{Category, Child, Object, Property, SceneDesc, Value};
use crate::error::{Location, SceneError};
use glam::{Affine2, DMat4, DVec3, Mat3, Vec2, Vec3, Vec4};
use gltf::khr_lights_punctual::Kind as LightKind;
use std::cell::Cell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;
use yubin_core::bsdf::{Mask, Material, NormalMap, Principled, TwoSided};
use yubin_core::light::{DirectionalLight, Emitter, PointLight, SpotLight};
use yubin_core::math::Transform;
use yubin_core::scene::ShapeEmitter;
use yubin_core::shape::{MeshShape, Shape, TriangleMesh};
use yubin_core::texture::image::ImageData;
use yubin_core::texture::{
    Bitmap, FilterType, MeshAttribute, NamedAttribute, Tex, TexImage, Texture, WrapMode,
};
use yubin_core::Rgb;

/// What a glTF file rendered on its own lacks, from the command line.
#[derive(Clone, Debug, Default)]
pub struct GltfOptions {
    /// Image width in pixels (default 1024).
    pub width: Option<u32>,
    /// Image height (default: from the width and the camera's aspect).
    pub height: Option<u32>,
    /// Samples per pixel (default 64).
    pub spp: Option<u32>,
    /// An environment map lighting the model (lat-long image).
    pub env: Option<PathBuf>,
}

/// Whether `path` names a glTF file (by its extension).
pub fn is_gltf(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// Loads a glTF file rendered on its own ([`parse_gltf`], then built).
pub fn load_gltf(path: &Path, options: &GltfOptions) -> Result<crate::LoadedScene, SceneError> {
    crate::build::build_scene(&parse_gltf(path, options)?)
}

/// The scene of a glTF file rendered on its own: its camera (or one
/// framing it), a film, a sampler, the environment, and the model as a
/// `gltf` shape.
pub fn parse_gltf(path: &Path, options: &GltfOptions) -> Result<SceneDesc, SceneError> {
    let file = Arc::new(path.to_path_buf());
    let loc = Location::new(file.clone(), 0);
    let gltf = open_checked(path)?;
    let doc = &gltf.document;
    let placed = placed_nodes(doc);
    let camera = placed.iter().find_map(|(n, m)| n.camera().map(|c| (c, *m)));
    let aspect = camera.as_ref().and_then(|(c, _)| match c.projection() {
        gltf::camera::Projection::Perspective(p) => p.aspect_ratio(),
        gltf::camera::Projection::Orthographic(o) => Some(o.xmag() / o.ymag()),
    });
    let width = options.width.unwrap_or(1024);
    let height = options.height.unwrap_or_else(|| {
        (width as f32 / aspect.unwrap_or(4.0 / 3.0))
            .round()
            .max(1.0) as u32
    });
    let sensor = match camera {
        Some((c, m)) => gltf_camera(&c, m, &loc),
        None => framing_camera(&placed, &loc),
    };
    let sensor = with_children(
        sensor,
        vec![
            object(
                Category::Film,
                "hdrfilm",
                &loc,
                vec![
                    prop("width", Value::Integer(width.into()), &loc),
                    prop("height", Value::Integer(height.into()), &loc),
                ],
            ),
            object(
                Category::Sampler,
                "independent",
                &loc,
                vec![prop(
                    "sample_count",
                    Value::Integer(options.spp.unwrap_or(64).into()),
                    &loc,
                )],
            ),
        ],
    );
    let has_lights = placed.iter().any(|(n, _)| n.light().is_some())
        || doc.materials().any(|m| m.emissive_factor() != [0.0; 3]);
    let mut top = vec![object(Category::Integrator, "path", &loc, vec![]), sensor];
    if let Some(env) = &options.env {
        let env = std::path::absolute(env).unwrap_or_else(|_| env.clone());
        top.push(object(
            Category::Emitter,
            "envmap",
            &loc,
            vec![prop(
                "filename",
                Value::String(env.to_string_lossy().into_owned()),
                &loc,
            )],
        ));
    } else if !has_lights {
        top.push(object(Category::Emitter, "constant", &loc, vec![]));
    }
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    top.push(object(
        Category::Shape,
        "gltf",
        &loc,
        vec![prop(
            "filename",
            Value::String(absolute.to_string_lossy().into_owned()),
            &loc,
        )],
    ));
    let root = with_children(object(Category::Scene, "scene", &loc, vec![]), top);
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    Ok(SceneDesc {
        root: Rc::new(root),
        version: (3, 0, 0),
        file: path.to_path_buf(),
        search_paths: vec![dir],
    })
}

fn prop(name: &str, value: Value, loc: &Location) -> Property {
    Property {
        name: name.to_string(),
        value,
        loc: loc.clone(),
        used: Cell::new(false),
        look_at_target: None,
    }
}

fn object(category: Category, kind: &str, loc: &Location, props: Vec<Property>) -> Object {
    let mut o = Object::new(category, kind, loc.clone());
    o.props = props;
    o
}

fn with_children(mut parent: Object, children: Vec<Object>) -> Object {
    let loc = parent.loc.clone();
    parent.children = children
        .into_iter()
        .map(|o| Child {
            name: None,
            object: Rc::new(o),
            loc: loc.clone(),
            used: Cell::new(false),
        })
        .collect();
    parent
}

/// A glTF camera looks along −z with +y up; Mitsuba's along +z with +x
/// to the left: the same frame turned 180° about y.
fn mitsuba_camera_frame(m: DMat4) -> DMat4 {
    m * DMat4::from_scale(DVec3::new(-1.0, 1.0, -1.0))
}

fn gltf_camera(c: &gltf::Camera, m: DMat4, loc: &Location) -> Object {
    let frame = mitsuba_camera_frame(without_scale(m));
    match c.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let mut props = vec![
                prop("fov", Value::Float(f64::from(p.yfov()).to_degrees()), loc),
                prop("fov_axis", Value::String("y".into()), loc),
                prop("to_world", Value::Transform(frame), loc),
                prop("near_clip", Value::Float(f64::from(p.znear())), loc),
            ];
            if let Some(far) = p.zfar() {
                props.push(prop("far_clip", Value::Float(f64::from(far)), loc));
            }
            object(Category::Sensor, "perspective", loc, props)
        }
        gltf::camera::Projection::Orthographic(o) => {
            // Mitsuba's window is x ∈ [−1, 1] before to_world's scale.
            let scale = DVec3::new(f64::from(o.xmag()), f64::from(o.xmag()), 1.0);
            let props = vec![
                prop(
                    "to_world",
                    Value::Transform(frame * DMat4::from_scale(scale)),
                    loc,
                ),
                prop("near_clip", Value::Float(f64::from(o.znear())), loc),
                prop("far_clip", Value::Float(f64::from(o.zfar())), loc),
            ];
            object(Category::Sensor, "orthographic", loc, props)
        }
    }
}

/// A node's matrix with its scale removed (a camera's scale would skew
/// its rays; glTF says cameras ignore it).
fn without_scale(m: DMat4) -> DMat4 {
    let (_, rotation, translation) = m.to_scale_rotation_translation();
    DMat4::from_rotation_translation(rotation, translation)
}

/// A 40° camera looking at the model's bounds from +z (glTF's front).
fn framing_camera(placed: &[(gltf::Node, DMat4)], loc: &Location) -> Object {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for (node, m) in placed {
        let Some(mesh) = node.mesh() else { continue };
        for p in mesh.primitives() {
            let b = p.bounding_box();
            for corner in 0..8 {
                let pick = |i: usize, a: [f32; 3], c: [f32; 3]| {
                    if corner >> i & 1 == 0 {
                        f64::from(a[i])
                    } else {
                        f64::from(c[i])
                    }
                };
                let c = DVec3::new(
                    pick(0, b.min, b.max),
                    pick(1, b.min, b.max),
                    pick(2, b.min, b.max),
                );
                let w = m.transform_point3(c);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
    }
    if !lo.is_finite() || !hi.is_finite() {
        lo = DVec3::splat(-1.0);
        hi = DVec3::splat(1.0);
    }
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-6);
    let fov = 40.0f64;
    let distance = radius / (fov.to_radians() * 0.5).sin() * 1.05;
    let origin = center + DVec3::Z * distance;
    let to_world = DMat4::look_at_lh(origin, center, DVec3::Y).inverse();
    object(
        Category::Sensor,
        "perspective",
        loc,
        vec![
            prop("fov", Value::Float(fov), loc),
            prop("fov_axis", Value::String("smaller".into()), loc),
            prop("to_world", Value::Transform(to_world), loc),
            prop("near_clip", Value::Float(distance * 1e-3), loc),
            prop(
                "far_clip",
                Value::Float(distance * 10.0 + radius * 4.0),
                loc,
            ),
        ],
    )
}

/// Every node of the default scene (else the first) with its world
/// matrix, parents before children.
fn placed_nodes(doc: &gltf::Document) -> Vec<(gltf::Node<'_>, DMat4)> {
    let mut out = Vec::new();
    let Some(scene) = doc.default_scene().or_else(|| doc.scenes().next()) else {
        return out;
    };
    let mut stack: Vec<(gltf::Node, DMat4)> = scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
    // A node may appear once in a scene by the spec; the depth bound keeps
    // a malformed cycle from running away.
    while let Some((node, parent)) = stack.pop() {
        if out.len() > 1_000_000 {
            break;
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        stack.extend(node.children().map(|c| (c, world)));
        out.push((node, world));
    }
    out
}

/// A glTF error with the file, and the JSON paths of validation errors.
fn gltf_error(path: &Path, e: gltf::Error) -> SceneError {
    let at = Location::new(Arc::new(path.to_path_buf()), 0);
    let msg = match e {
        gltf::Error::Validation(errors) => {
            let list: Vec<String> = errors
                .iter()
                .map(|(p, err)| format!("{}: {err}", json_pointer(p.as_str())))
                .collect();
            format!("invalid glTF: {}", list.join("; "))
        }
        other => format!("glTF: {other}"),
    };
    SceneError::at(&at, msg)
}

/// A path as the `gltf` crate writes it (`meshes[0].primitives[1]`) as
/// a JSON pointer (`/meshes/0/primitives/1`).
fn json_pointer(path: &str) -> String {
    let mut out = String::from("/");
    out.push_str(&path.replace('[', "/").replace(']', "").replace('.', "/"));
    out.replace("//", "/")
}

/// The file, its buffers and its images, read and checked: every buffer
/// and image file it names must exist (named by its JSON pointer), and
/// every accessor must lie inside its buffer view and buffer.
fn import(
    path: &Path,
) -> Result<
    (
        gltf::Document,
        Vec<gltf::buffer::Data>,
        Vec<gltf::image::Data>,
    ),
    SceneError,
> {
    let at = Location::new(Arc::new(path.to_path_buf()), 0);
    let gltf = open_checked(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let external = |uri: &str| !uri.starts_with("data:") && !uri.contains('%');
    let buffers = gltf.buffers().filter_map(|b| match b.source() {
        gltf::buffer::Source::Uri(u) => Some((format!("/buffers/{}", b.index()), u)),
        gltf::buffer::Source::Bin => None,
    });
    let images = gltf.images().filter_map(|i| match i.source() {
        gltf::image::Source::Uri { uri, .. } => Some((format!("/images/{}", i.index()), uri)),
        gltf::image::Source::View { .. } => None,
    });
    for (pointer, uri) in buffers.chain(images) {
        if external(uri) && !dir.join(uri).is_file() {
            return Err(SceneError::at(
                &at,
                format!(
                    "{pointer}: \"{uri}\" not found (looked in {})",
                    dir.display()
                ),
            ));
        }
    }
    check_accessors(&gltf.document, &at)?;
    check_attributes(&gltf.document, &at)?;
    check_hierarchy(&gltf.document, &at)?;
    let buffers = gltf::import_buffers(&gltf.document, Some(dir), gltf.blob)
        .map_err(|e| gltf_error(path, e))?;
    let images = gltf::import_images(&gltf.document, Some(dir), &buffers)
        .map_err(|e| gltf_error(path, e))?;
    Ok((gltf.document, buffers, images))
}

/// The file's JSON (and GLB binary chunk), validated. A primitive whose
/// POSITION names no accessor is caught first: the `gltf` crate's own
/// validation indexes the accessors with it unchecked.
fn open_checked(path: &Path) -> Result<gltf::Gltf, SceneError> {
    let at = Location::new(Arc::new(path.to_path_buf()), 0);
    let bytes = std::fs::read(path).map_err(|e| SceneError::at(&at, format!("glTF: {e}")))?;
    check_glb_length(&bytes, &at)?;
    let unchecked =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| gltf_error(path, e))?;
    let json = unchecked.document.as_json();
    for (i, m) in json.meshes.iter().enumerate() {
        for (j, p) in m.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(a) = p.attributes.get(&position) {
                if a.value() >= json.accessors.len() {
                    return Err(SceneError::at(
                        &at,
                        format!(
                            "/meshes/{i}/primitives/{j}/attributes/POSITION: accessor {} does \
                             not exist ({} accessors)",
                            a.value(),
                            json.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    // Validated once, from the JSON already parsed.
    let gltf::Gltf { document, blob } = unchecked;
    let document =
        gltf::Document::from_json(document.into_json()).map_err(|e| gltf_error(path, e))?;
    Ok(gltf::Gltf { document, blob })
}

/// A GLB's total length is at least its 12-byte header: the `gltf` crate
/// subtracts the header from it unchecked (an overflow panic in debug
/// builds).
pub(crate) fn check_glb_length(bytes: &[u8], at: &Location) -> Result<(), SceneError> {
    const HEADER: usize = 12;
    let Some(field) = bytes.strip_prefix(b"glTF").and_then(|b| b.get(4..8)) else {
        return Ok(());
    };
    let length = u32::from_le_bytes(field.try_into().unwrap());
    if (length as usize) < HEADER {
        return Err(SceneError::at(
            at,
            format!("GLB header: total length {length} is shorter than the {HEADER}-byte header"),
        ));
    }
    Ok(())
}

/// Every accessor's bytes lie inside its buffer view, and every view
/// inside its buffer (the `gltf` crate checks indices, not extents).
fn check_accessors(doc: &gltf::Document, at: &Location) -> Result<(), SceneError> {
    for v in doc.views() {
        let end = v.offset() as u64 + v.length() as u64;
        if end > v.buffer().length() as u64 {
            return Err(SceneError::at(
                at,
                format!(
                    "/bufferViews/{}: bytes {}..{end} lie outside buffer {} ({} bytes)",
                    v.index(),
                    v.offset(),
                    v.buffer().index(),
                    v.buffer().length()
                ),
            ));
        }
    }
    for a in doc.accessors() {
        let Some(v) = a.view() else { continue };
        if a.count() == 0 {
            continue;
        }
        let element = a.size() as u64;
        let stride = v.stride().map_or(element, |s| s as u64);
        if stride < element {
            return Err(SceneError::at(
                at,
                format!(
                    "/accessors/{}: elements of {element} bytes in buffer view {} with a \
                     stride of {stride}",
                    a.index(),
                    v.index()
                ),
            ));
        }
        let end = a.offset() as u64 + stride * (a.count() as u64 - 1) + element;
        if end > v.length() as u64 {
            return Err(SceneError::at(
                at,
                format!(
                    "/accessors/{}: {} elements of {element} bytes from byte {} need {end} bytes, \
                     but buffer view {} has {}",
                    a.index(),
                    a.count(),
                    a.offset(),
                    v.index(),
                    v.length()
                ),
            ));
        }
    }
    Ok(())
}

/// Every attribute the renderer reads has the type the spec requires
/// (the reader would otherwise reinterpret its bytes).
fn check_attributes(doc: &gltf::Document, at: &Location) -> Result<(), SceneError> {
    use gltf::accessor::{DataType as T, Dimensions as D};
    use gltf::Semantic as S;
    for m in doc.meshes() {
        for p in m.primitives() {
            let place = format!("/meshes/{}/primitives/{}", m.index(), p.index());
            let wrong = |what: &str, must: &str, a: &gltf::Accessor| {
                SceneError::at(
                    at,
                    format!(
                        "{place}/{what}: accessor {} holds {:?} {:?}; it must be {must}",
                        a.index(),
                        a.data_type(),
                        a.dimensions()
                    ),
                )
            };
            for (semantic, a) in p.attributes() {
                let (ty, dims) = (a.data_type(), a.dimensions());
                let small = matches!(ty, T::F32 | T::U8 | T::U16);
                let (ok, must) = match &semantic {
                    S::Positions | S::Normals => ((ty, dims) == (T::F32, D::Vec3), "F32 Vec3"),
                    S::Tangents => ((ty, dims) == (T::F32, D::Vec4), "F32 Vec4"),
                    S::TexCoords(_) => (dims == D::Vec2 && small, "F32, U8 or U16 Vec2"),
                    S::Colors(_) => (
                        matches!(dims, D::Vec3 | D::Vec4) && small,
                        "F32, U8 or U16 Vec3 or Vec4",
                    ),
                    _ => (true, ""),
                };
                if !ok {
                    return Err(wrong(
                        &format!("attributes/{}", semantic.to_string()),
                        must,
                        &a,
                    ));
                }
            }
            if let Some(a) = p.indices() {
                let ok =
                    a.dimensions() == D::Scalar && matches!(a.data_type(), T::U8 | T::U16 | T::U32);
                if !ok {
                    return Err(wrong("indices", "U8, U16 or U32 Scalar", &a));
                }
            }
        }
    }
    Ok(())
}

/// Nodes form trees: no node with two parents, no cycle (the spec's rule,
/// which the `gltf` crate does not check; a cycle would place a mesh
/// without end).
fn check_hierarchy(doc: &gltf::Document, at: &Location) -> Result<(), SceneError> {
    let mut parent: Vec<Option<usize>> = vec![None; doc.nodes().len()];
    for n in doc.nodes() {
        for c in n.children() {
            if let Some(first) = parent[c.index()].replace(n.index()) {
                return Err(SceneError::at(
                    at,
                    format!(
                        "/nodes/{}: a child of both node {first} and node {} (nodes form trees)",
                        c.index(),
                        n.index()
                    ),
                ));
            }
        }
    }
    for start in 0..parent.len() {
        let (mut node, mut steps) = (start, 0);
        while let Some(p) = parent[node] {
            node = p;
            steps += 1;
            if steps > parent.len() {
                return Err(SceneError::at(
                    at,
                    format!("/nodes/{start}: its own ancestor (the node hierarchy has a cycle)"),
                ));
            }
        }
    }
    Ok(())
}

/// The decoded file.
struct Model {
    doc: gltf::Document,
    buffers: Vec<gltf::buffer::Data>,
    images: Vec<gltf::image::Data>,
}

/// The mesh attribute vertex colours (times the base colour factor) go
/// to.
const VERTEX_COLOUR: &str = "vertex_color";

/// Which use an image is decoded for (the channels it keeps and how).
#[derive(Clone, Copy, Debug, Hash, PartialEq, Eq)]
enum ImageUse {
    /// sRGB colour times a factor.
    Color([u32; 3]),
    /// One linear channel (0 red … 3 alpha) times a factor.
    Channel(usize, u32),
    /// A tangent-space normal map with its scale.
    Normal(u32),
    /// Alpha against a cutoff (opacity 0 or 1) times a factor.
    Cutoff(u32, u32),
}

/// Imports a glTF model into the scene being built.
pub(crate) struct Importer<'b, 'a> {
    b: &'b mut Builder<'a>,
    model: Model,
    file: PathBuf,
    /// Images by (glTF image, use).
    images: HashMap<(usize, ImageUse), u32>,
    /// BSDFs by (material, has uvs, has vertex colours).
    bsdfs: HashMap<(Option<usize>, bool, bool), (u32, bool)>,
}

impl Builder<'_> {
    /// `<shape type="gltf">`: the model's meshes, materials and lights,
    /// placed by `to_world` in shape group `group` (0: the world).
    pub(crate) fn gltf_shape(&mut self, obj: &Object, group: u32) -> Result<(), SceneError> {
        let name = obj
            .string("filename")?
            .ok_or_else(|| obj.error("needs a \"filename\""))?;
        let path = self.desc.resolve_file(name, obj.loc_of("filename"))?;
        let to_world = obj.transform("to_world")?;
        let (doc, buffers, images) = import(&path)?;
        let mut importer = Importer {
            b: self,
            model: Model {
                doc,
                buffers,
                images,
            },
            file: path,
            images: HashMap::new(),
            bsdfs: HashMap::new(),
        };
        importer.import(to_world, group)
    }
}

impl Importer<'_, '_> {
    fn error(&self, msg: impl std::fmt::Display) -> SceneError {
        SceneError::at(
            &Location::new(Arc::new(self.file.clone()), 0),
            msg.to_string(),
        )
    }

    fn import(&mut self, to_world: DMat4, group: u32) -> Result<(), SceneError> {
        let doc = self.model.doc.clone();
        let placed: Vec<(usize, Option<usize>, DMat4)> = placed_nodes(&doc)
            .into_iter()
            .map(|(n, m)| (n.index(), n.mesh().map(|m| m.index()), to_world * m))
            .collect();
        let mut uses: HashMap<usize, usize> = HashMap::new();
        for (_, mesh, _) in &placed {
            if let Some(m) = mesh {
                *uses.entry(*m).or_default() += 1;
            }
        }
        let mut groups: HashMap<usize, u32> = HashMap::new();
        for &(node, mesh, m) in &placed {
            if let Some(mesh) = mesh {
                if uses[&mesh] > 1 && group == 0 {
                    let g = match groups.get(&mesh) {
                        Some(&g) => g,
                        None => {
                            let g = self.b.sb.add_group();
                            self.add_mesh(mesh, DMat4::IDENTITY, g)?;
                            groups.insert(mesh, g);
                            g
                        }
                    };
                    let t = transform(m).ok_or_else(|| {
                        self.error(format!("node {node}: a transform that cannot be inverted"))
                    })?;
                    self.b
                        .sb
                        .add_instance(g, t)
                        .map_err(|e| self.error(format!("node {node}: {e}")))?;
                } else {
                    self.add_mesh(mesh, m, group)?;
                }
            }
            let light = doc.nodes().nth(node).and_then(|n| n.light());
            if let Some(light) = light {
                self.add_light(&light, m)?;
            }
        }
        Ok(())
    }

    /// Adds mesh `mesh`'s triangle primitives, placed by `m`, to `group`.
    fn add_mesh(&mut self, mesh: usize, m: DMat4, group: u32) -> Result<(), SceneError> {
        let doc = self.model.doc.clone();
        let Some(gmesh) = doc.meshes().nth(mesh) else {
            return Err(self.error(format!("/meshes/{mesh} does not exist")));
        };
        let t = transform(m)
            .ok_or_else(|| self.error(format!("/meshes/{mesh}: placed by a singular transform")))?;
        for p in gmesh.primitives() {
            let at = format!("/meshes/{mesh}/primitives/{}", p.index());
            if p.mode() != gltf::mesh::Mode::Triangles {
                self.b.warnings.push(format!(
                    "{}: {at}: mode {:?} skipped (only triangles are rendered)",
                    self.file.display(),
                    p.mode()
                ));
                continue;
            }
            let (mut tri, colours) = self.read_primitive(&p, &at)?;
            tri.transform(&t);
            let has_uvs = !tri.uvs.is_empty();
            let material = p.material();
            let pbr = material.pbr_metallic_roughness();
            let textured = has_uvs && pbr.base_color_texture().is_some();
            if colours.is_some() && textured {
                self.b.warnings.push(format!(
                    "{}: {at}: vertex colours under a base colour texture are ignored",
                    self.file.display()
                ));
            }
            if let Some(mut c) = colours.filter(|_| !textured) {
                // The factor is baked in: the colour is factor × COLOR_0.
                let f = pbr.base_color_factor();
                for rgb in c.chunks_exact_mut(3) {
                    for (v, f) in rgb.iter_mut().zip(f) {
                        *v *= f;
                    }
                }
                let named = NamedAttribute {
                    name: VERTEX_COLOUR.to_string(),
                    channels: 3,
                    values: c,
                };
                tri = tri
                    .with_attributes(vec![named])
                    .map_err(|e| self.error(format!("{at}: {e}")))?;
            }
            let coloured = !tri.attributes.is_empty();
            let (bsdf, needs_tangents) = self.bsdf(material, has_uvs, coloured)?;
            if needs_tangents && tri.tangents.is_empty() && !tri.compute_tangents() {
                return Err(self.error(format!("{at}: no MikkTSpace tangents for its normal map")));
            }
            let emission = self.emission(&p.material())?;
            let mesh_id = self.b.sb.add_mesh(tri);
            self.b
                .sb
                .add_shape_with_emitter(
                    group,
                    Shape::Mesh(MeshShape { mesh: mesh_id }),
                    Some(bsdf),
                    emission.map(ShapeEmitter::Area),
                )
                .map_err(|e| self.error(format!("{at}: {e}")))?;
        }
        Ok(())
    }

    /// The primitive's triangles (with its tangents where it has them)
    /// and its vertex colours (`COLOR_0`, RGB).
    fn read_primitive(
        &self,
        p: &gltf::Primitive,
        at: &str,
    ) -> Result<(TriangleMesh, Option<Vec<f32>>), SceneError> {
        let buffers = &self.model.buffers;
        let reader = p.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| self.error(format!("{at}: no POSITION attribute")))?
            .map(Vec3::from)
            .collect();
        let normals: Vec<Vec3> = reader
            .read_normals()
            .map(|n| n.map(Vec3::from).collect())
            .unwrap_or_default();
        let uvs: Vec<Vec2> = reader
            .read_tex_coords(0)
            .map(|t| t.into_f32().map(Vec2::from).collect())
            .unwrap_or_default();
        let flat: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..positions.len() as u32).collect(),
        };
        if !flat.len().is_multiple_of(3) {
            return Err(self.error(format!(
                "{at}: {} indices do not make whole triangles",
                flat.len()
            )));
        }
        let indices: Vec<[u32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let normals = if normals.len() == positions.len() {
            normals
        } else {
            Vec::new()
        };
        let uvs = if uvs.len() == positions.len() {
            uvs
        } else {
            Vec::new()
        };
        let tangents: Vec<Vec4> = reader
            .read_tangents()
            .map(|t| t.map(Vec4::from).collect())
            .unwrap_or_default();
        let colours: Option<Vec<f32>> = reader
            .read_colors(0)
            .map(|c| c.into_rgb_f32().flatten().collect())
            .filter(|c: &Vec<f32>| c.len() == positions.len() * 3);
        let count = positions.len();
        let mut mesh = TriangleMesh::new(positions, normals, uvs, indices, false, false)
            .map_err(|e| self.error(format!("{at}: {e}")))?;
        if tangents.len() == count && !mesh.uvs.is_empty() {
            mesh.tangents = mesh
                .indices
                .iter()
                .map(|t| t.map(|v| tangents[v as usize]))
                .collect();
        }
        Ok((mesh, colours))
    }

    /// The BSDF of glTF material `material` (None: the default material)
    /// on a mesh with or without uvs, and whether it reads MikkTSpace
    /// tangents.
    fn bsdf(
        &mut self,
        material: gltf::Material,
        has_uvs: bool,
        has_colours: bool,
    ) -> Result<(u32, bool), SceneError> {
        let key = (material.index(), has_uvs, has_colours);
        if let Some(&found) = self.bsdfs.get(&key) {
            return Ok(found);
        }
        let pbr = material.pbr_metallic_roughness();
        let [r, g, b, a] = pbr.base_color_factor();
        let base = pbr.base_color_texture().filter(|_| has_uvs);
        let base_color = match &base {
            Some(t) => self.texture(
                t.texture(),
                t.texture_transform(),
                ImageUse::Color(bits([r, g, b])),
            )?,
            None if has_colours => {
                let name = self.b.sb.attribute_name(VERTEX_COLOUR);
                let t = Texture::MeshAttribute(MeshAttribute { name, scale: 1.0 });
                Tex::Texture(self.b.sb.add_texture(t))
            }
            None => Tex::Const(Rgb::new(r, g, b)),
        };
        let mr = pbr.metallic_roughness_texture().filter(|_| has_uvs);
        let (metallic, roughness) = match &mr {
            Some(t) => (
                self.texture(
                    t.texture(),
                    t.texture_transform(),
                    ImageUse::Channel(2, pbr.metallic_factor().to_bits()),
                )?,
                self.texture(
                    t.texture(),
                    t.texture_transform(),
                    ImageUse::Channel(1, pbr.roughness_factor().to_bits()),
                )?,
            ),
            None => (
                Tex::value(pbr.metallic_factor()),
                Tex::value(pbr.roughness_factor()),
            ),
        };
        let mut principled = Principled::new(Rgb::ONE);
        principled.common.base_color = base_color;
        principled.common.roughness = roughness;
        principled.metallic = metallic;
        let mut id = self.b.sb.add_bsdf(Material::Principled(principled));
        let mut tangents = false;
        if let Some(n) = material.normal_texture().filter(|_| has_uvs) {
            let map = self.texture(n.texture(), None, ImageUse::Normal(n.scale().to_bits()))?;
            id = self.b.sb.add_bsdf(Material::NormalMap(NormalMap {
                normalmap: map,
                mikktspace: true,
                nested: id,
            }));
            tangents = true;
        }
        if material.double_sided() {
            id = self.b.sb.add_bsdf(Material::TwoSided(TwoSided {
                front: id,
                back: id,
            }));
        }
        let opacity = match material.alpha_mode() {
            gltf::material::AlphaMode::Opaque => None,
            gltf::material::AlphaMode::Mask => {
                let cutoff = material.alpha_cutoff().unwrap_or(0.5);
                Some(match &base {
                    Some(t) => self.texture(
                        t.texture(),
                        t.texture_transform(),
                        ImageUse::Cutoff(cutoff.to_bits(), a.to_bits()),
                    )?,
                    None => Tex::value(if a >= cutoff { 1.0 } else { 0.0 }),
                })
            }
            gltf::material::AlphaMode::Blend => Some(match &base {
                Some(t) => self.texture(
                    t.texture(),
                    t.texture_transform(),
                    ImageUse::Channel(3, a.to_bits()),
                )?,
                None => Tex::value(a.clamp(0.0, 1.0)),
            }),
        };
        if let Some(opacity) = opacity {
            id = self.b.sb.add_bsdf(Material::Mask(Mask {
                opacity,
                nested: id,
            }));
        }
        self.bsdfs.insert(key, (id, tangents));
        Ok((id, tangents))
    }

    /// The radiance a material emits (factor × texture × strength).
    fn emission(&mut self, material: &gltf::Material) -> Result<Option<Tex>, SceneError> {
        let strength = material.emissive_strength().unwrap_or(1.0);
        let f = material.emissive_factor().map(|c| c * strength);
        if f == [0.0; 3] {
            return Ok(None);
        }
        Ok(Some(match material.emissive_texture() {
            Some(t) => {
                self.texture(t.texture(), t.texture_transform(), ImageUse::Color(bits(f)))?
            }
            None => Tex::Const(Rgb::from(f)),
        }))
    }

    /// A bitmap texture of glTF texture `t` decoded for `usage`.
    fn texture(
        &mut self,
        t: gltf::Texture,
        transform: Option<gltf::texture::TextureTransform>,
        usage: ImageUse,
    ) -> Result<Tex, SceneError> {
        let source = t.source().index();
        let image = match self.images.get(&(source, usage)) {
            Some(&i) => i,
            None => {
                let img = self.decode(source, usage)?;
                let i = self.b.sb.add_image(img);
                self.images.insert((source, usage), i);
                i
            }
        };
        let sampler = t.sampler();
        let filter = match sampler.mag_filter() {
            Some(gltf::texture::MagFilter::Nearest) => FilterType::Nearest,
            _ => FilterType::Bilinear,
        };
        let mode = |w| match w {
            gltf::texture::WrappingMode::ClampToEdge => WrapMode::Clamp,
            gltf::texture::WrappingMode::MirroredRepeat => WrapMode::Mirror,
            gltf::texture::WrappingMode::Repeat => WrapMode::Repeat,
        };
        let wrap = [mode(sampler.wrap_s()), mode(sampler.wrap_t())];
        let raw = !matches!(usage, ImageUse::Color(_));
        let id = self.b.sb.add_texture(Texture::Bitmap(Bitmap {
            image,
            filter,
            wrap,
            raw,
            to_uv: uv_transform(transform.as_ref()),
        }));
        Ok(Tex::Texture(id))
    }

    /// Image `source` as `usage` needs it.
    fn decode(&self, source: usize, usage: ImageUse) -> Result<TexImage, SceneError> {
        let data = self
            .model
            .images
            .get(source)
            .ok_or_else(|| self.error(format!("/images/{source} does not exist")))?;
        use gltf::image::Format as F;
        // (channels, bytes per channel, float), as the decoder stores them
        // (native-endian words).
        let (channels, size, float) = match data.format {
            F::R8 => (1, 1, false),
            F::R8G8 => (2, 1, false),
            F::R8G8B8 => (3, 1, false),
            F::R8G8B8A8 => (4, 1, false),
            F::R16 => (1, 2, false),
            F::R16G16 => (2, 2, false),
            F::R16G16B16 => (3, 2, false),
            F::R16G16B16A16 => (4, 2, false),
            F::R32G32B32FLOAT => (3, 4, true),
            F::R32G32B32A32FLOAT => (4, 4, true),
        };
        let (w, h) = (data.width, data.height);
        let n = w as usize * h as usize;
        let bad = || self.error(format!("/images/{source}: its pixels do not fill {w}×{h}"));
        if data.pixels.len() < n * channels * size {
            return Err(bad());
        }
        // Channel `ch` of pixel `i`, in [0, 1] for integer data.
        let read = |i: usize, ch: usize| -> f32 {
            let at = (i * channels + ch) * size;
            let b = &data.pixels[at..at + size];
            match (size, float) {
                (1, _) => f32::from(b[0]) / 255.0,
                (2, _) => f32::from(u16::from_ne_bytes([b[0], b[1]])) / 65535.0,
                _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
            }
        };
        // Grey images (with or without alpha) repeat their one colour.
        let texel = |i: usize, c: usize| read(i, if channels >= 3 { c } else { 0 });
        let alpha = |i: usize| match channels {
            4 => read(i, 3),
            2 => read(i, 1),
            _ => 1.0,
        };
        // Colour is sRGB-encoded in 8- and 16-bit images, linear in float.
        let linear = |v: f32| {
            if float {
                v
            } else {
                yubin_core::texture::image::srgb_to_linear(v)
            }
        };
        let image = match usage {
            ImageUse::Color(f) if f == bits([1.0; 3]) && size == 1 => {
                // Kept 8-bit and encoded, as bitmaps keep PNGs.
                let px: Vec<u8> = (0..n)
                    .flat_map(|i| (0..3).map(move |c| (i, c)))
                    .map(|(i, c)| data.pixels[i * channels + if channels >= 3 { c } else { 0 }])
                    .collect();
                TexImage::new(w, h, 3, ImageData::U8(px), true)
            }
            ImageUse::Color(f) => {
                let f = f.map(f32::from_bits);
                let px: Vec<f32> = (0..n)
                    .flat_map(|i| (0..3).map(move |c| (i, c)))
                    .map(|(i, c)| linear(texel(i, c)) * f[c])
                    .collect();
                TexImage::new(w, h, 3, ImageData::F32(px), false)
            }
            ImageUse::Channel(c, f) => {
                let f = f32::from_bits(f);
                let px: Vec<f32> = (0..n)
                    .map(|i| if c == 3 { alpha(i) } else { texel(i, c) } * f)
                    .collect();
                TexImage::new(w, h, 1, ImageData::F32(px), false)
            }
            ImageUse::Cutoff(cutoff, f) => {
                let (cutoff, f) = (f32::from_bits(cutoff), f32::from_bits(f));
                let px: Vec<f32> = (0..n)
                    .map(|i| if alpha(i) * f >= cutoff { 1.0 } else { 0.0 })
                    .collect();
                TexImage::new(w, h, 1, ImageData::F32(px), false)
            }
            ImageUse::Normal(s) => {
                let s = f32::from_bits(s);
                let px: Vec<f32> = (0..n)
                    .flat_map(|i| {
                        let v = Vec3::new(texel(i, 0), texel(i, 1), texel(i, 2)) * 2.0 - Vec3::ONE;
                        let v = (v * Vec3::new(s, s, 1.0))
                            .try_normalize()
                            .unwrap_or(Vec3::Z);
                        ((v + Vec3::ONE) * 0.5).to_array()
                    })
                    .collect();
                TexImage::new(w, h, 3, ImageData::F32(px), false)
            }
        };
        image.ok_or_else(bad)
    }

    fn add_light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        m: DMat4,
    ) -> Result<(), SceneError> {
        let intensity = Rgb::from(light.color()) * (light.intensity() / LUMENS_PER_WATT);
        let position = m.transform_point3(DVec3::ZERO).as_vec3();
        let emitter = match light.kind() {
            LightKind::Point => Emitter::Point(PointLight {
                position,
                intensity,
            }),
            LightKind::Directional => Emitter::Directional(DirectionalLight {
                direction: m
                    .transform_vector3(DVec3::NEG_Z)
                    .as_vec3()
                    .try_normalize()
                    .unwrap_or(Vec3::NEG_Z),
                irradiance: intensity,
            }),
            LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                // Mitsuba's spot shines along +z: turn glTF's −z onto it.
                let frame = without_scale(m) * DMat4::from_scale(DVec3::new(1.0, -1.0, -1.0));
                let t = transform(frame)
                    .ok_or_else(|| self.error("a spot light placed by a singular transform"))?;
                let cutoff = outer_cone_angle.clamp(1e-4, std::f32::consts::FRAC_PI_2);
                Emitter::Spot(SpotLight::new(
                    t,
                    intensity,
                    cutoff,
                    inner_cone_angle.clamp(0.0, cutoff),
                ))
            }
        };
        self.b.sb.add_emitter(emitter);
        Ok(())
    }
}

/// glTF's lights are photometric (candela, lux); yubin's radiometric.
/// The conversion at the luminous efficacy of 555 nm light is the one
/// Blender's exporter applies to its watts, so a Blender light keeps the
/// power it had in Blender.
const LUMENS_PER_WATT: f32 = 683.0;

/// Factors as bits, for hashing a decoding.
fn bits(f: [f32; 3]) -> [u32; 3] {
    f.map(f32::to_bits)
}

/// A matrix as yubin's transform (`None` when singular).
fn transform(m: DMat4) -> Option<Transform> {
    Transform::from_mat4(m.as_mat4())
}

/// `KHR_texture_transform` as the bitmap's uv transform (the same uv
/// convention: no change of axes).
fn uv_transform(t: Option<&gltf::texture::TextureTransform>) -> Affine2 {
    t.map_or(Affine2::IDENTITY, |t| {
        uv_transform_of(t.offset(), t.rotation(), t.scale())
    })
}

/// The extension's matrix: translation · rotation · scale.
fn uv_transform_of([ox, oy]: [f32; 2], rotation: f32, [sx, sy]: [f32; 2]) -> Affine2 {
    let (s, c) = rotation.sin_cos();
    Affine2::from_mat3(Mat3::from_cols(
        Vec3::new(c * sx, s * sx, 0.0),
        Vec3::new(-s * sy, c * sy, 0.0),
        Vec3::new(ox, oy, 1.0),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `KHR_texture_transform`: offset, then the spec's rotation (which
    /// takes u towards +v) and scale, as its sample model checks them.
    #[test]
    fn texture_transforms_follow_the_extension() {
        let close = |a: Vec2, b: Vec2| (a - b).length() < 1e-6;
        let offset = uv_transform_of([0.5, 0.25], 0.0, [1.0, 1.0]);
        assert!(close(
            offset.transform_point2(Vec2::ZERO),
            Vec2::new(0.5, 0.25)
        ));
        let turned = uv_transform_of([0.0, 0.0], std::f32::consts::FRAC_PI_2, [1.0, 1.0]);
        assert!(
            close(turned.transform_point2(Vec2::X), Vec2::Y),
            "{}",
            turned.transform_point2(Vec2::X)
        );
        let scaled = uv_transform_of([1.0, 0.0], 0.0, [2.0, 3.0]);
        assert!(close(
            scaled.transform_point2(Vec2::ONE),
            Vec2::new(3.0, 3.0)
        ));
        assert_eq!(uv_transform(None), Affine2::IDENTITY);
    }
}
