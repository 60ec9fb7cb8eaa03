//! Loading `aov` and `ao` from Mitsuba XML: named nested integrators become
//! layers, and bad AOV lists are load errors that name the file and line.

use std::path::Path;
use yubin_scene::build::load_scene_str;

fn scene(integrator: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
{integrator}
<shape type="sphere"/>
<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
</scene>"#
    )
}

fn layer_names(xml: &str) -> Vec<String> {
    let loaded = load_scene_str(&scene(xml), Path::new("aov.xml"), &[]).unwrap();
    loaded
        .integrator
        .extra_layers()
        .iter()
        .flat_map(|l| l.channels.iter().map(move |c| format!("{}.{c}", l.name)))
        .collect()
}

#[test]
fn aov_layers_from_xml() {
    let names = layer_names(
        r#"<integrator type="aov">
    <string name="aovs" value="nn:sh_normal, depth.y:depth"/>
    <integrator type="path" name="image"/>
    <integrator type="moment" name="mom"><integrator type="direct"/></integrator>
</integrator>"#,
    );
    assert_eq!(
        names,
        [
            "image.R",
            "image.G",
            "image.B",
            "image.A",
            "mom.R",
            "mom.G",
            "mom.B",
            "mom.A",
            "mom.m2.R",
            "mom.m2.G",
            "mom.m2.B",
            "nn.X",
            "nn.Y",
            "nn.Z",
            "depth.y.T"
        ]
    );
    let ao = layer_names(
        r#"<integrator type="ao"><integer name="shading_samples" value="4"/></integrator>"#,
    );
    assert!(ao.is_empty());
}

#[test]
fn bad_aov_lists_are_errors_with_file_and_line() {
    for (xml, line, needle) in [
        (
            r#"<integrator type="aov">
    <string name="aovs" value="dd:depht"/>
</integrator>"#,
            "aov.xml:3:",
            "unsupported AOV type \"depht\"",
        ),
        (
            r#"<integrator type="aov">
    <string name="aovs" value="dd:depth"/>
    <integrator type="path"/>
</integrator>"#,
            "aov.xml:4:",
            "needs a name",
        ),
    ] {
        let Err(err) = load_scene_str(&scene(xml), Path::new("aov.xml"), &[]) else {
            panic!("{needle}: the scene loaded");
        };
        let err = err.to_string();
        assert!(err.contains(line), "{err}");
        assert!(err.contains(needle), "{err}");
    }
}

/// AOVs beside a path tracer keep its MIS compensation; one nested
/// integrator that must sample lights whole (`direct` without BSDF
/// samples) turns it off for all, as they share the scene's lights.
#[test]
fn aov_compensates_when_every_nested_integrator_does() {
    let compensates = |xml: &str| {
        load_scene_str(&scene(xml), Path::new("aov.xml"), &[])
            .unwrap()
            .integrator
            .mis_compensation()
    };
    let aov = |nested: &str| {
        format!(
            r#"<integrator type="aov"><string name="aovs" value="dd:depth"/>{nested}</integrator>"#
        )
    };
    assert!(compensates(&aov(
        r#"<integrator type="path" name="image"/>"#
    )));
    assert!(!compensates(&aov(
        r#"<integrator type="path" name="a"/><integrator type="direct" name="b"><integer name="bsdf_samples" value="0"/></integrator>"#
    )));
    assert!(!compensates(&aov("")));
}

/// A sphere's hits carry their uv wherever something can read it: an
/// `aov` integrator (its uv AOV) or any texture of the scene; a path
/// tracer in an untextured scene lets the sphere skip it.
#[test]
fn sphere_uv_is_computed_where_something_reads_it() {
    let uv_seen = |integrator: &str, extra: &str| {
        let xml = scene(integrator).replace(
            "<shape type=\"sphere\"/>",
            &format!("<shape type=\"sphere\"/>{extra}"),
        );
        let loaded = load_scene_str(&xml, Path::new("aov.xml"), &[]).unwrap();
        let ray = yubin_core::math::Ray::new(
            glam::Vec3::new(0.3, 0.2, -5.0),
            glam::Vec3::new(0.0, 0.0, 1.0),
        );
        loaded.scene.intersect(&ray).unwrap().uv
    };
    let aov = r#"<integrator type="aov"><string name="aovs" value="t:uv"/><integrator type="path" name="image"/></integrator>"#;
    let path = r#"<integrator type="path"/>"#;
    let texture = r#"<shape type="rectangle"><transform name="to_world"><translate z="9"/></transform>
        <bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf></shape>"#;
    assert_ne!(uv_seen(aov, ""), glam::Vec2::ZERO);
    assert_ne!(uv_seen(path, texture), glam::Vec2::ZERO);
    assert_eq!(uv_seen(path, ""), glam::Vec2::ZERO);
}
