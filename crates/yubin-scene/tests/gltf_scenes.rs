//! glTF 2.0 scenes: a model and the same scene written by hand in Mitsuba
//! XML render alike, a model placed in XML by `<shape type="gltf">`, bad
//! files are clear errors naming the file and the JSON pointer, and the
//! sample models of `../shared` come out the right way up.

use std::path::{Path, PathBuf};
use yubin_core::render::{render, RenderSettings};
use yubin_scene::gltf::{load_gltf, GltfOptions};
use yubin_scene::{load_scene_str, LoadedScene};

/// A fresh directory for one test's files.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("yubin-gltf-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Little-endian bytes of floats and integers, as a glTF buffer holds them.
fn bytes_f32(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn bytes_u16(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A quad facing +z (two triangles) and a floor below it, as raw data.
const POSITIONS: [f32; 24] = [
    -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0, //
    -4.0, -1.0, 4.0, 4.0, -1.0, 4.0, 4.0, -1.0, -4.0, -4.0, -1.0, -4.0,
];
const INDICES: [u16; 12] = [0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7];

/// The glTF of the quad and floor (a red rough dielectric), a camera at
/// z = 5 and a point light, its buffer in `scene.bin`.
fn write_gltf(dir: &Path) -> PathBuf {
    let nodes = format!(r#"{{"mesh": 0}}, {CAMERA_NODE}, {LIGHT_NODE}"#);
    let camera = r#"{"type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.01, "aspectRatio": 1.5}}"#;
    let material = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.3, 0.2, 1], "metallicFactor": 0, "roughnessFactor": 0.5}}"#;
    write_gltf_with(dir, "scene.gltf", &nodes, 3, material, camera)
}

/// The quad and floor's buffer and a glTF using it: `nodes` (JSON, the
/// first `roots` of them the scene's), one `material` and one `camera`.
fn write_gltf_with(
    dir: &Path,
    name: &str,
    nodes: &str,
    roots: usize,
    material: &str,
    camera: &str,
) -> PathBuf {
    let mut bin = bytes_f32(&POSITIONS);
    bin.extend(bytes_u16(&INDICES));
    std::fs::write(dir.join("scene.bin"), &bin).unwrap();
    let roots: Vec<String> = (0..roots).map(|i| i.to_string()).collect();
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [
    {{"type": "point", "color": [1, 0.9, 0.8], "intensity": 20000}}]}}}},
  "scene": 0,
  "scenes": [{{"nodes": [{}]}}],
  "nodes": [{nodes}],
  "cameras": [{camera}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{material}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3", "min": [-4, -1, -4], "max": [4, 1, 4]}},
    {{"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 96}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 24}}
  ],
  "buffers": [{{"uri": "scene.bin", "byteLength": {}}}]
}}"#,
        roots.join(", "),
        bin.len()
    );
    let path = dir.join(name);
    std::fs::write(&path, json).unwrap();
    path
}

/// The same scene by hand: the mesh as an OBJ, `principled`, the camera
/// turned as glTF's −z view becomes Mitsuba's +z.
fn write_xml(dir: &Path) -> String {
    let mut obj = String::new();
    for p in POSITIONS.chunks(3) {
        obj += &format!("v {:?} {:?} {:?}\n", p[0], p[1], p[2]);
    }
    for t in INDICES.chunks(3) {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    let fov = f64::from(0.6f32).to_degrees();
    let near = f64::from(0.01f32);
    // Candela become W/sr at 683 lm/W.
    let intensity = |c: f32| c * (20000.0f32 / 683.0);
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="{fov:?}"/>
        <string name="fov_axis" value="y"/>
        <float name="near_clip" value="{near:?}"/>
        <transform name="to_world">
            <matrix value="-1 0 0 0  0 1 0 0  0 0 -1 5  0 0 0 1"/>
        </transform>
        <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="32"/></film>
        <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
    </sensor>
    <emitter type="point">
        <point name="position" x="1" y="3" z="3"/>
        <rgb name="intensity" value="{:?}, {:?}, {:?}"/>
    </emitter>
    <shape type="obj">
        <string name="filename" value="scene.obj"/>
        <bsdf type="principled">
            <rgb name="base_color" value="0.8, 0.3, 0.2"/>
            <float name="metallic" value="0"/>
            <float name="roughness" value="0.5"/>
        </bsdf>
    </shape>
</scene>"#,
        intensity(1.0),
        intensity(0.9),
        intensity(0.8)
    )
}

fn image(s: &LoadedScene) -> Vec<f32> {
    let settings = RenderSettings { spp: 8, seed: 3 };
    render(&s.scene, s.integrator.as_ref(), &settings, &|_| {})
        .image
        .data
}

fn options() -> GltfOptions {
    GltfOptions {
        width: Some(48),
        height: None,
        spp: Some(8),
        env: None,
    }
}

#[test]
fn a_gltf_scene_renders_as_the_same_scene_in_xml() {
    let dir = scratch("same");
    let gltf = load_gltf(&write_gltf(&dir), &options()).expect("the glTF loads");
    let xml = write_xml(&dir);
    let xml = load_scene_str(&xml, &dir.join("scene.xml"), &[]).expect("the XML loads");
    let (a, b) = (image(&gltf), image(&xml));
    assert!(a.iter().any(|&v| v > 0.0), "the glTF scene renders black");
    assert!(a == b, "the glTF and XML scenes differ");
}

#[test]
fn a_gltf_model_can_be_placed_in_xml() {
    let dir = scratch("placed");
    write_gltf(&dir);
    let xml = r#"<scene version="3.0.0">
        <sensor type="perspective"><float name="fov" value="40"/>
            <transform name="to_world"><lookat origin="0,0,8" target="0,0,0" up="0,1,0"/></transform>
            <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
        </sensor>
        <shape type="gltf">
            <string name="filename" value="scene.gltf"/>
            <transform name="to_world"><translate y="0.5"/></transform>
        </shape>
    </scene>"#;
    let loaded = load_scene_str(xml, &dir.join("placed.xml"), &[]).expect("the scene loads");
    // The model's light comes with it.
    assert!(image(&loaded).iter().any(|&v| v > 0.0));
}

/// The error of loading `json` (buffer-less or with `scene.bin` beside it).
fn error_of(name: &str, json: &str) -> String {
    let dir = scratch(name);
    let path = dir.join("bad.gltf");
    std::fs::write(&path, json).unwrap();
    match load_gltf(&path, &options()) {
        Ok(_) => panic!("{name}: a bad file loaded"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_files_are_errors_naming_the_file_and_the_place() {
    let missing = error_of(
        "missing",
        r#"{"asset": {"version": "2.0"}, "buffers": [{"uri": "gone.bin", "byteLength": 12}]}"#,
    );
    assert!(
        missing.contains("bad.gltf")
            && missing.contains("/buffers/0")
            && missing.contains("gone.bin"),
        "{missing}"
    );
    let accessor = error_of(
        "accessor",
        r#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 3}}]}]}"#,
    );
    assert!(
        accessor.contains("bad.gltf") && accessor.contains("/meshes/0/primitives/0/attributes"),
        "{accessor}"
    );
    let extension = error_of(
        "extension",
        r#"{"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_draco_mesh_compression"],
            "extensionsRequired": ["KHR_draco_mesh_compression"]}"#,
    );
    assert!(
        extension.contains("bad.gltf")
            && extension.contains("/extensionsRequired/0")
            && extension.contains("KHR_draco_mesh_compression"),
        "{extension}"
    );
    let short = error_of(
        "short",
        &format!(
            r#"{{"asset": {{"version": "2.0"}}, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
            "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 30, "type": "VEC3",
                "min": [0, 0, 0], "max": [1, 1, 1]}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
            "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": 36}}]}}"#,
            "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"
        ),
    );
    assert!(
        short.contains("bad.gltf") && short.contains("/accessors/0"),
        "{short}"
    );
}

/// The glTF sample model that shows which way texture coordinates run:
/// each quad's corner marks (black checkers) sit in the corner its label
/// names, so the top-left quad has them at its top left, not its bottom
/// left (v upside down) or top right (u mirrored).
#[test]
fn texture_coordinate_test_comes_out_the_right_way_up_shared() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/assets/gltf/TextureCoordinateTest/TextureCoordinateTest.gltf");
    if !path.exists() {
        println!("skipped: {} is absent", path.display());
        return;
    }
    let options = GltfOptions {
        width: Some(200),
        height: Some(150),
        spp: Some(4),
        env: None,
    };
    let s = load_gltf(&path, &options).expect("the sample model loads");
    let img = render(
        &s.scene,
        s.integrator.as_ref(),
        &RenderSettings { spp: 4, seed: 1 },
        &|_| {},
    )
    .image;
    // The darkest mean luminance of a small window around (fx, fy), as
    // fractions of the image: a checker mark is dark, the quads bright.
    let dark = |fx: f32, fy: f32| {
        let (cx, cy) = ((fx * 200.0) as i32, (fy * 150.0) as i32);
        let mut sum = 0.0;
        for y in cy - 3..=cy + 3 {
            for x in cx - 3..=cx + 3 {
                let (x, y) = (x.clamp(0, 199) as u32, y.clamp(0, 149) as u32);
                sum += (0..3).map(|c| img.get(x, y, c)).sum::<f32>();
            }
        }
        sum / 49.0
    };
    // The top-left quad spans about x 0.27–0.46, y 0.19–0.45 of the frame.
    let (top_left, bottom_left, top_right) = (dark(0.29, 0.21), dark(0.29, 0.43), dark(0.44, 0.21));
    assert!(
        top_left < 0.7 * bottom_left && top_left < 0.7 * top_right,
        "marks at top left {top_left}, bottom left {bottom_left}, top right {top_right}"
    );
}

fn write_variant(dir: &Path, nodes: &str, roots: usize, material: &str, camera: &str) -> PathBuf {
    write_gltf_with(dir, "variant.gltf", nodes, roots, material, camera)
}

const CAMERA_NODE: &str = r#"{"camera": 0, "translation": [0, 0, 5]}"#;
const LIGHT_NODE: &str =
    r#"{"translation": [1, 3, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}}"#;
const PERSPECTIVE: &str = r#"{"type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.01}}"#;
const RED: &str = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.3, 0.2, 1]}}"#;

/// A mesh three nodes use is built once and placed by instances.
#[test]
fn a_mesh_used_by_several_nodes_is_instanced() {
    let dir = scratch("instances");
    let nodes = format!(
        r#"{{"mesh": 0, "translation": [-2, 0, -3]}}, {{"mesh": 0}}, {{"mesh": 0, "translation": [2, 0, -3]}}, {CAMERA_NODE}, {LIGHT_NODE}"#
    );
    let path = write_variant(&dir, &nodes, 5, RED, PERSPECTIVE);
    let s = load_gltf(&path, &options()).expect("the instanced model loads");
    assert_eq!(s.scene.meshes.len(), 1, "the shared mesh was copied");
    assert!(image(&s).iter().any(|&v| v > 0.0));
}

/// Orthographic cameras, alpha modes and double-sided materials map onto
/// `orthographic`, `mask` and `twosided`.
#[test]
fn orthographic_cameras_alpha_modes_and_double_sided_materials_map() {
    use yubin_core::bsdf::Material;
    use yubin_core::texture::Tex;
    let dir = scratch("modes");
    let nodes = format!(r#"{{"mesh": 0}}, {CAMERA_NODE}, {LIGHT_NODE}"#);
    let ortho = r#"{"type": "orthographic", "orthographic": {"xmag": 2, "ymag": 1.5, "znear": 0.01, "zfar": 100}}"#;
    let masked = r#"{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.3]}, "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": true}"#;
    let s = load_gltf(&write_variant(&dir, &nodes, 3, masked, ortho), &options()).unwrap();
    assert!(matches!(
        s.scene.camera,
        yubin_core::camera::Camera::Orthographic(_)
    ));
    // xmag : ymag is the image's aspect ratio.
    assert_eq!((s.scene.film.width, s.scene.film.height), (48, 36));
    let bsdfs = &s.scene.materials.bsdfs;
    // Alpha 0.3 under the cutoff 0.5: fully transparent.
    assert!(bsdfs
        .iter()
        .any(|b| matches!(b, Material::Mask(m) if m.opacity == Tex::value(0.0))));
    assert!(bsdfs.iter().any(|b| matches!(b, Material::TwoSided(_))));
    let blended =
        r#"{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.3]}, "alphaMode": "BLEND"}"#;
    let s = load_gltf(
        &write_variant(&dir, &nodes, 3, blended, PERSPECTIVE),
        &options(),
    )
    .unwrap();
    let bsdfs = &s.scene.materials.bsdfs;
    assert!(bsdfs
        .iter()
        .any(|b| matches!(b, Material::Mask(m) if m.opacity == Tex::value(0.3))));
    assert!(!bsdfs.iter().any(|b| matches!(b, Material::TwoSided(_))));
}

/// Malformed files the `gltf` crate lets through (or panics on) are
/// errors naming the file and the JSON pointer: a stride shorter than an
/// element, attributes of the wrong type, a node hierarchy with a cycle.
#[test]
fn malformed_hierarchies_and_attributes_are_errors() {
    let dir = scratch("malformed");
    let good = std::fs::read_to_string(write_gltf(&dir)).unwrap();
    let cases = [
        (
            "stride",
            good.replace(
                r#""byteOffset": 0, "byteLength": 96}"#,
                r#""byteOffset": 0, "byteLength": 96, "byteStride": 4}"#,
            ),
            "/accessors/0",
        ),
        (
            "position type",
            good.replace(
                r#""count": 8, "type": "VEC3""#,
                r#""count": 8, "type": "VEC2""#,
            ),
            "/meshes/0/primitives/0/attributes/POSITION",
        ),
        (
            "cycle",
            good.replace(
                r#"{"mesh": 0}, {"camera""#,
                r#"{"mesh": 0, "children": [1]}, {"children": [0], "camera""#,
            ),
            "/nodes/",
        ),
    ];
    for (name, json, pointer) in cases {
        assert_ne!(json, good, "{name}: the mutation did not apply");
        let path = dir.join("malformed.gltf");
        std::fs::write(&path, json).unwrap();
        let err = match load_gltf(&path, &options()) {
            Ok(_) => panic!("{name}: a malformed file loaded"),
            Err(e) => e.to_string(),
        };
        assert!(
            err.contains("malformed.gltf") && err.contains(pointer),
            "{name}: {err}"
        );
    }
}

/// The quad-and-floor glTF of [`write_gltf`] with one more vertex
/// attribute (`name`, of accessor `kind` such as `"VEC3"`), its floats in
/// `file`, and its material replaced by `material` (the JSON after
/// `"materials": [`, up to and including the material's closing brace).
fn with_attribute(
    dir: &Path,
    name: &str,
    kind: &str,
    values: &[f32],
    file: &str,
    material: &str,
) -> String {
    std::fs::write(dir.join(file), bytes_f32(values)).unwrap();
    let len = values.len() * 4;
    let json = std::fs::read_to_string(write_gltf(dir))
        .unwrap()
        .replace(
            r#""attributes": {"POSITION": 0}"#,
            &format!(r#""attributes": {{"POSITION": 0, "{name}": 2}}"#),
        )
        .replace(
            r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.3, 0.2, 1], "metallicFactor": 0, "roughnessFactor": 0.5}}"#,
            material,
        )
        .replace(
            r#"{"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}"#,
            &format!(
                r#"{{"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}},
    {{"bufferView": 2, "componentType": 5126, "count": 8, "type": "{kind}"}}"#
            ),
        )
        .replace(
            r#"{"buffer": 0, "byteOffset": 96, "byteLength": 24}"#,
            &format!(
                r#"{{"buffer": 0, "byteOffset": 96, "byteLength": 24}},
    {{"buffer": 1, "byteLength": {len}}}"#
            ),
        )
        .replace(
            r#""buffers": [{"uri": "scene.bin", "byteLength": 120}]"#,
            &format!(
                r#""buffers": [{{"uri": "scene.bin", "byteLength": 120}}, {{"uri": "{file}", "byteLength": {len}}}]"#
            ),
        );
    assert!(
        json.contains(file) && json.contains(name),
        "the edit did not apply"
    );
    json
}

/// `COLOR_0` times the base colour factor colours the surface (as the
/// `vertex_color` attribute the base colour reads).
#[test]
fn vertex_colours_tint_the_base_colour() {
    let dir = scratch("colours");
    // Green vertices under a factor that halves green and keeps red at 0.
    let colours: Vec<f32> = (0..8).flat_map(|_| [1.0, 1.0, 0.0]).collect();
    let material = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0, 0.5, 1, 1]}}"#;
    let json = with_attribute(&dir, "COLOR_0", "VEC3", &colours, "colours.bin", material);
    let path = dir.join("coloured.gltf");
    std::fs::write(&path, json).unwrap();
    let s = load_gltf(&path, &options()).expect("the coloured model loads");
    let img = render(
        &s.scene,
        s.integrator.as_ref(),
        &RenderSettings { spp: 8, seed: 3 },
        &|_| {},
    )
    .image;
    // The middle of the frame is the quad: (1, 1, 0) × (0, 0.5, 1) is green.
    let (w, h) = (img.width / 2, img.height / 2);
    let [r, g, b] = [0, 1, 2].map(|c| img.get(w, h, c));
    assert!(
        g > 0.0 && g > 4.0 * r && g > 4.0 * b,
        "the quad is {r} {g} {b}, not green"
    );
}

/// A 16-bit grey-and-alpha PNG: the grey is every colour channel (sRGB
/// decoded at 16 bits), the alpha the opacity of a `BLEND` material.
#[test]
fn sixteen_bit_grey_alpha_textures_decode() {
    use yubin_core::texture::image::{srgb_to_linear, ImageData};
    let dir = scratch("grey16");
    let (grey, alpha) = (40000u16, 30000u16);
    let png =
        image::ImageBuffer::<image::LumaA<u16>, _>::from_pixel(2, 2, image::LumaA([grey, alpha]));
    png.save(dir.join("grey.png")).unwrap();
    let uvs: Vec<f32> = (0..8).flat_map(|_| [0.5, 0.5]).collect();
    let material = r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "alphaMode": "BLEND"}],
  "textures": [{"source": 0}],
  "images": [{"uri": "grey.png"}"#;
    let json = with_attribute(&dir, "TEXCOORD_0", "VEC2", &uvs, "uvs.bin", material);
    let path = dir.join("grey.gltf");
    std::fs::write(&path, json).unwrap();
    let s = load_gltf(&path, &options()).expect("the model loads");
    let first = |img: &yubin_core::texture::TexImage| match &img.data {
        ImageData::F32(v) => v[0],
        ImageData::U8(v) => f32::from(v[0]) / 255.0,
    };
    let images = &s.scene.materials.images;
    let colour = images
        .iter()
        .find(|i| i.channels == 3)
        .expect("the colour image");
    let opacity = images
        .iter()
        .find(|i| i.channels == 1)
        .expect("the opacity image");
    let want = srgb_to_linear(f32::from(grey) / 65535.0);
    assert!(
        (first(colour) - want).abs() < 1e-6,
        "colour {} vs {want}",
        first(colour)
    );
    let want = f32::from(alpha) / 65535.0;
    assert!(
        (first(opacity) - want).abs() < 1e-6,
        "opacity {} vs {want}",
        first(opacity)
    );
}
