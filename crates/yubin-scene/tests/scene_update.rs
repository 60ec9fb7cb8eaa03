//! `Scene::update` against a fresh load: editing a loaded scene and
//! rendering it again gives, bit for bit, the image of loading the edited
//! file, and rebuilds only what the edit needs (counted, not timed). A bad
//! edit is an error naming the key and leaves the scene as it was.

use glam::{DMat4, DVec3};
use std::path::Path;
use yubin_core::bsdf::{Material, RoughTransmittance};
use yubin_core::params::ParamValue;
use yubin_core::render::{render, RenderSettings};
use yubin_core::Rgb;
use yubin_scene::{load_scene_str, LoadedScene};

/// A small scene with the placeholders `{wall}` (an RGB reflectance),
/// `{radiance}`, `{camera}` (a transform's inside), `{ball}` and
/// `{instance}` (translations).
const SCENE: &str = r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world">{camera}</transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="24"/><integer name="height" value="18"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <bsdf type="diffuse" id="red"><rgb name="reflectance" value="{wall}"/></bsdf>
    <bsdf type="roughconductor" id="metal"><float name="alpha" value="0.2"/></bsdf>
    <shape type="rectangle" id="wall">
        <boolean name="flip_normals" value="true"/>
        <transform name="to_world"><scale value="3"/><translate z="2"/></transform>
        <ref id="red"/>
    </shape>
    <shape type="sphere" id="ball">
        <float name="radius" value="0.5"/>
        <transform name="to_world"><translate {ball}/></transform>
        <ref id="metal"/>
    </shape>
    <shape type="shapegroup" id="pair">
        <shape type="cube">
            <transform name="to_world"><scale value="0.3"/></transform>
        </shape>
    </shape>
    <shape type="disk" id="floor">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="2"/><translate y="-1"/></transform>
        <bsdf type="diffuse">
            <texture type="checkerboard" name="reflectance">
                <rgb name="color0" value="{check}"/>
                <rgb name="color1" value="0.1, 0.1, 0.1"/>
            </texture>
        </bsdf>
    </shape>
    <shape type="instance" id="boxes">
        <ref id="pair"/>
        <transform name="to_world"><translate {instance}/></transform>
    </shape>
    <shape type="rectangle" id="light">
        <transform name="to_world"><rotate x="1" angle="90"/><translate y="2"/></transform>
        <emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter>
    </shape>
    <emitter type="constant" id="sky"><rgb name="radiance" value="{sky}"/></emitter>
</scene>"#;

struct Edit {
    wall: &'static str,
    radiance: &'static str,
    camera: &'static str,
    ball: &'static str,
    instance: &'static str,
    sky: &'static str,
    check: &'static str,
}

const BASE: Edit = Edit {
    wall: "0.6, 0.2, 0.1",
    radiance: "5, 5, 5",
    camera: r#"<lookat origin="0, 0, -4" target="0, 0, 0" up="0, 1, 0"/>"#,
    ball: r#"x="0.5" y="0" z="0""#,
    instance: r#"x="-1" y="-0.5" z="0.5""#,
    sky: "0.2, 0.2, 0.3",
    check: "0.8, 0.8, 0.2",
};

fn text(e: &Edit) -> String {
    SCENE
        .replace("{wall}", e.wall)
        .replace("{radiance}", e.radiance)
        .replace("{camera}", e.camera)
        .replace("{ball}", e.ball)
        .replace("{instance}", e.instance)
        .replace("{sky}", e.sky)
        .replace("{check}", e.check)
}

fn load_text(text: &str) -> LoadedScene {
    load_scene_str(text, Path::new("update.xml"), &[]).expect("the test scene loads")
}

fn load(e: &Edit) -> LoadedScene {
    load_text(&text(e))
}

fn image(s: &LoadedScene) -> Vec<f32> {
    let settings = RenderSettings { spp: 4, seed: 7 };
    render(&s.scene, s.integrator.as_ref(), &settings, &|_| {})
        .image
        .data
}

fn translation(x: f64, y: f64, z: f64) -> ParamValue {
    ParamValue::Transform(DMat4::from_translation(DVec3::new(x, y, z)))
}

/// Updates `key` of the base scene to `value`, and checks the render
/// against a fresh load of `edited`; returns how many BVHs the update
/// built.
fn check_update(key: &str, value: ParamValue, edited: &Edit) -> u64 {
    let mut s = load(&BASE);
    let before = image(&s);
    let counts = s.scene.rebuild_counts();
    s.scene.update(key, value).expect("a valid update");
    let after = s.scene.rebuild_counts();
    assert_eq!(
        after.meshes_added, counts.meshes_added,
        "{key}: no mesh is added again"
    );
    let updated = image(&s);
    let fresh = image(&load(edited));
    assert!(updated != before, "{key}: the edit changes the image");
    assert!(
        updated == fresh,
        "{key}: the update renders as a fresh load"
    );
    after.bvh_builds - counts.bvh_builds
}

#[test]
fn a_material_edit_renders_as_the_edited_file_and_builds_no_bvh() {
    let edited = Edit {
        wall: "0.1, 0.5, 0.8",
        ..BASE
    };
    let value = ParamValue::Color(Rgb::new(0.1, 0.5, 0.8));
    assert_eq!(check_update("red.reflectance.value", value, &edited), 0);
}

#[test]
fn a_float_edit_renders_as_the_edited_file() {
    let mut s = load(&BASE);
    s.scene
        .update("metal.alpha.value", ParamValue::Float(0.05))
        .unwrap();
    let alpha = |v: &str| format!(r#"name="alpha" value="{v}""#);
    let fresh = load_text(&text(&BASE).replace(&alpha("0.2"), &alpha("0.05")));
    assert!(image(&s) == image(&fresh));
    assert!(
        image(&s) != image(&load(&BASE)),
        "the edit changes the image"
    );
}

#[test]
fn an_emitter_edit_renders_as_the_edited_file_and_builds_no_bvh() {
    let edited = Edit {
        radiance: "2, 3, 9",
        ..BASE
    };
    let value = ParamValue::Color(Rgb::new(2.0, 3.0, 9.0));
    assert_eq!(
        check_update("light.emitter.radiance.value", value, &edited),
        0
    );
}

#[test]
fn an_environment_edit_renders_as_the_edited_file_and_builds_no_bvh() {
    let edited = Edit {
        sky: "0.5, 0.1, 0.05",
        ..BASE
    };
    let value = ParamValue::Color(Rgb::new(0.5, 0.1, 0.05));
    assert_eq!(check_update("sky.radiance.value", value, &edited), 0);
}

#[test]
fn a_texture_edit_renders_as_the_edited_file_and_builds_no_bvh() {
    let edited = Edit {
        check: "0.2, 0.9, 0.9",
        ..BASE
    };
    let value = ParamValue::Color(Rgb::new(0.2, 0.9, 0.9));
    let key = "floor.bsdf.reflectance.color0.value";
    assert_eq!(check_update(key, value, &edited), 0);
}

#[test]
fn a_medium_edit_renders_as_the_edited_file() {
    let fog = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/fog.xml");
    let text = std::fs::read_to_string(&fog).expect("scenes/fog.xml");
    let small = |text: &str| {
        let defines = [("resx", "24"), ("resy", "18"), ("spp", "4")];
        let defines = defines.map(|(k, v)| (k.to_string(), v.to_string()));
        load_scene_str(text, &fog, &defines).expect("the fog scene loads")
    };
    let mut s = small(&text);
    let before = image(&s);
    s.scene.update("fog.scale", ParamValue::Float(3.0)).unwrap();
    (s.scene)
        .update("fog.phase_function.g", ParamValue::Float(-0.2))
        .unwrap();
    let edited = text
        .replace(r#"value="$fog""#, r#"value="3""#)
        .replace(r#"name="g" value="0.3""#, r#"name="g" value="-0.2""#);
    assert!(image(&s) != before, "the edit changes the image");
    assert!(image(&s) == image(&small(&edited)));
}

#[test]
fn a_camera_edit_renders_as_the_edited_file_and_builds_no_bvh() {
    let edited = Edit {
        camera: r#"<translate x="0.25" y="0.5" z="-5"/>"#,
        ..BASE
    };
    assert_eq!(
        check_update("sensor.to_world", translation(0.25, 0.5, -5.0), &edited),
        0
    );
}

#[test]
fn a_shape_transform_renders_as_the_edited_file() {
    let edited = Edit {
        ball: r#"x="-0.25" y="0.5" z="0""#,
        ..BASE
    };
    let builds = check_update("ball.to_world", translation(-0.25, 0.5, 0.0), &edited);
    assert_eq!(builds, 1, "only the world's BVH is built again");
}

#[test]
fn an_instance_transform_renders_as_the_edited_file() {
    let edited = Edit {
        instance: r#"x="1" y="0.5" z="0""#,
        ..BASE
    };
    let builds = check_update("boxes.to_world", translation(1.0, 0.5, 0.0), &edited);
    assert_eq!(builds, 1, "only the top level is built again");
}

#[test]
fn parameters_list_the_editable_values_with_stable_keys() {
    let s = load(&BASE);
    let params = s.scene.parameters();
    let find = |key: &str| params.iter().find(|p| p.key == key);
    let wall = find("red.reflectance.value").expect("the wall's colour");
    assert_eq!(wall.value, Some(ParamValue::Color(Rgb::new(0.6, 0.2, 0.1))));
    for key in [
        "light.emitter.radiance.value",
        "sensor.to_world",
        "sensor.fov",
        "sensor.film.width",
        "ball.to_world",
        "ball.radius",
        "boxes.to_world",
        "metal.alpha.value",
    ] {
        assert!(find(key).is_some(), "{key} in {params:#?}");
    }
}

#[test]
fn a_bad_update_names_the_key_and_leaves_the_scene_unchanged() {
    let mut s = load(&BASE);
    let before = image(&s);
    let params = s.scene.parameters();
    let bad = [
        ("red.reflectance.value", ParamValue::Boolean(true), "colour"),
        ("red.roughness", ParamValue::Float(0.1), "red.roughness"),
        ("nothing.at.all", ParamValue::Float(0.1), "nothing.at.all"),
        (
            "red.reflectance.value",
            ParamValue::Color(Rgb::new(-1.0, 0.5, 0.5)),
            "must be finite and not negative",
        ),
        ("metal.alpha.value", ParamValue::Float(-2.0), "not negative"),
        (
            "sensor.film.width",
            ParamValue::Integer(-5),
            "must be a positive integer",
        ),
        (
            "ball.radius",
            ParamValue::String("big".into()),
            "is a float",
        ),
        (
            "sensor.sampler.seed",
            ParamValue::Integer(3),
            "RenderSettings::seed",
        ),
    ];
    for (key, value, says) in bad {
        let e = s.scene.update(key, value).expect_err(key).to_string();
        assert!(e.contains(key), "{e}");
        assert!(e.contains(says), "{e}");
    }
    assert_eq!(s.scene.parameters(), params);
    assert!(image(&s) == before, "the scene is unchanged");
}

#[test]
fn an_id_keeps_its_key_whatever_comes_before_it() {
    let xml = r#"<scene version="3.0.0">
        <shape type="sphere"><float name="radius" value="0.5"/></shape>
        <shape type="sphere" id="sphere"><float name="radius" value="2"/></shape>
        <shape type="sphere"/>
    </scene>"#;
    let s = load_text(xml);
    let radius = |key: &str| {
        let params = s.scene.parameters();
        let p = params.iter().find(|p| p.key == key).cloned();
        p.unwrap_or_else(|| panic!("{key} in {params:#?}")).value
    };
    assert_eq!(radius("sphere.radius"), Some(ParamValue::Float(2.0)));
    assert_eq!(radius("sphere_1.radius"), Some(ParamValue::Float(0.5)));
    assert_eq!(radius("sphere_2.radius"), None);
}

/// A rough plastic's layer tables are made once per interface: editing α
/// back and forth finds the tables made the first time.
#[test]
fn editing_a_rough_plastic_back_and_forth_reuses_its_tables() {
    let xml = r#"<scene version="3.0.0">
        <shape type="sphere"><bsdf type="roughplastic" id="p"/></shape>
    </scene>"#;
    let mut s = load_text(xml);
    let mut tables_for = |alpha: f32| {
        s.scene
            .update("p.alpha.value", ParamValue::Float(alpha))
            .unwrap();
        let found = s.scene.materials.bsdfs.iter().find_map(|b| match b {
            Material::RoughPlastic(r) => Some(r.transmittance),
            _ => None,
        });
        found.expect("the rough plastic") as *const RoughTransmittance
    };
    let (a, b) = (tables_for(0.137), tables_for(0.291));
    assert_ne!(a, b);
    for _ in 0..5 {
        assert_eq!((tables_for(0.137), tables_for(0.291)), (a, b));
    }
}

#[test]
fn a_parameter_left_at_its_default_can_be_set() {
    let glass = |ior: &str| {
        format!(
            r#"<scene version="3.0.0">
            <sensor type="perspective">
                <transform name="to_world"><lookat origin="0, 0, -4" target="0, 0, 0" up="0, 1, 0"/></transform>
                <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
                <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="12"/></film>
            </sensor>
            <emitter type="constant"/>
            <shape type="sphere"><bsdf type="dielectric" id="glass">{ior}</bsdf></shape>
        </scene>"#
        )
    };
    let mut s = load_text(&glass(""));
    let params = s.scene.parameters();
    let ior = params.iter().find(|p| p.key == "glass.int_ior");
    assert_eq!(ior.map(|p| p.value.clone()), Some(None), "{params:#?}");
    let before = image(&s);
    s.scene
        .update("glass.int_ior", ParamValue::Float(1.8))
        .unwrap();
    let fresh = load_text(&glass(r#"<float name="int_ior" value="1.8"/>"#));
    assert!(image(&s) != before, "the edit changes the image");
    assert!(image(&s) == image(&fresh));
}
