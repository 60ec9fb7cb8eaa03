//! Parts of Mitsuba 3's scene vocabulary that its own test scenes use:
//! `rawconstant` as a texture, `to_world` on `constvolume`, and the
//! `checkerboard` read as a float with Mitsuba's colours swapped (and
//! yubin's `consistent_float` reading).

mod common;

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::load_scene_str;

fn scene(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="3"/></integrator>
<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, -4, 3" target="0, 0, 0" up="0, 0, 1"/></transform>
  <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/></film>
</sensor>
<emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
<emitter type="point"><point name="position" value="1, -2, 3"/><rgb name="intensity" value="10"/></emitter>
{body}
</scene>"#
    )
}

fn image(body: &str) -> Vec<f32> {
    let loaded =
        load_scene_str(&scene(body), Path::new("test.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp: 4, seed: 3 },
        &|_| {},
    )
    .image
    .data
}

const SPHERE: &str = r#"<shape type="sphere">BSDF</shape>"#;

fn with_bsdf(bsdf: &str) -> String {
    SPHERE.replace("BSDF", bsdf)
}

#[test]
fn rawconstant_textures_give_their_values() {
    // A constant roughness given raw equals the plain float.
    let raw = image(&with_bsdf(
        r#"<bsdf type="roughconductor"><texture type="rawconstant" name="alpha"><float name="value" value="0.3"/></texture></bsdf>"#,
    ));
    let plain = image(&with_bsdf(
        r#"<bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf>"#,
    ));
    let close = raw
        .iter()
        .zip(&plain)
        .all(|(a, b)| (a - b).abs() <= 1e-5 * (1.0 + b.abs()));
    assert!(close, "rawconstant alpha differs from the float");
    // A flat normal map given as a raw vector changes nothing; a tilted
    // one does.
    let flat = image(&with_bsdf(
        r#"<bsdf type="normalmap"><texture type="rawconstant" name="normalmap"><vector name="value" value="0.5, 0.5, 1"/></texture><bsdf type="diffuse"/></bsdf>"#,
    ));
    let tilted = image(&with_bsdf(
        r#"<bsdf type="normalmap"><texture type="rawconstant" name="normalmap"><vector name="value" value="0.9, 0.5, 0.7"/></texture><bsdf type="diffuse"/></bsdf>"#,
    ));
    let bare = image(&with_bsdf(r#"<bsdf type="diffuse"/>"#));
    let diff = |a: &[f32], b: &[f32]| {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f32>() / a.len() as f32
    };
    assert!(diff(&flat, &bare) < 1e-4, "{}", diff(&flat, &bare));
    assert!(diff(&tilted, &bare) > 1e-2, "{}", diff(&tilted, &bare));
}

#[test]
fn constvolume_accepts_to_world() {
    image(
        r#"<medium type="homogeneous" id="fog">
             <volume type="constvolume" name="albedo"><rgb name="value" value="0.5"/>
               <transform name="to_world"><scale value="2"/></transform></volume>
           </medium>
           <shape type="sphere"><ref name="interior" id="fog"/><bsdf type="null"/></shape>"#,
    );
}

/// Mitsuba 3 reads a checkerboard's `color1` where its colour reading
/// gives `color0` when the checkerboard is a float: a blend weight
/// checkered (0.2, 0.9) renders as yubin's consistent reading of
/// (0.9, 0.2), bit for bit, and not as its consistent reading of
/// (0.2, 0.9).
#[test]
fn checkerboard_as_a_float_swaps_its_colours_as_mitsuba_does() {
    let blend = |c0: f32, c1: f32, consistent: bool| {
        image(&with_bsdf(&format!(
            r#"<bsdf type="blendbsdf">
                 <texture type="checkerboard" name="weight">
                   <float name="color0" value="{c0}"/><float name="color1" value="{c1}"/>
                   <boolean name="consistent_float" value="{consistent}"/>
                   <transform name="to_uv"><scale value="4"/></transform>
                 </texture>
                 <bsdf type="diffuse"><rgb name="reflectance" value="0.9, 0.1, 0.1"/></bsdf>
                 <bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.1, 0.9"/></bsdf>
               </bsdf>"#
        )))
    };
    let mitsuba = blend(0.2, 0.9, false);
    assert_eq!(mitsuba, blend(0.9, 0.2, true));
    assert_ne!(mitsuba, blend(0.2, 0.9, true));
}

/// Mitsuba's spectral and polarized variants' plugins are refused at
/// their line with a message that says why (yubin renders in RGB), not
/// as unknown types.
#[test]
fn spectral_and_polarized_plugins_say_yubin_renders_rgb() {
    let error = |text: &str| match load_scene_str(text, Path::new("spectral.xml"), &[]) {
        Ok(_) => panic!("{text} loaded"),
        Err(e) => e.to_string(),
    };
    let film = error(
        r#"<scene version="3.0.0">
<sensor type="perspective">
  <film type="specfilm"/>
</sensor>
</scene>"#,
    );
    assert!(film.contains("spectral.xml:3"), "{film}");
    assert!(
        film.contains("\"specfilm\" is one of Mitsuba 3's spectral plugins")
            && film.contains("yubin renders in RGB"),
        "{film}"
    );
    for (tag, plugin) in [
        ("bsdf", "pplastic"),
        ("bsdf", "polarizer"),
        ("integrator", "stokes"),
    ] {
        let e = error(&format!(
            r#"<scene version="3.0.0"><{tag} type="{plugin}" id="x"/></scene>"#
        ));
        assert!(
            e.contains(&format!(
                "\"{plugin}\" is one of Mitsuba 3's polarization plugins"
            )),
            "{e}"
        );
    }
    // An unknown name is still unknown.
    let e = error(&scene(r#"<bsdf type="difuse" id="x"/>"#));
    assert!(e.contains("unknown bsdf type \"difuse\""), "{e}");
}

/// Mitsuba 3's `merge` shape renders its shapes as if written on their
/// own (Mitsuba joins its meshes for speed, not for looks); a `to_world`
/// on it is an error, as in Mitsuba, and a `<bsdf>` in it is ignored with
/// a warning.
#[test]
fn merge_renders_its_shapes_as_written() {
    let shapes = r#"<bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.7, 0.2, 0.1"/></bsdf>
<shape type="cube"><transform name="to_world"><scale value="0.4"/><translate x="-0.6"/></transform><ref id="red"/></shape>
<shape type="rectangle"><transform name="to_world"><translate z="-0.5"/></transform><ref id="red"/></shape>
<shape type="sphere"><point name="center" value="0.6, 0, 0"/><float name="radius" value="0.4"/></shape>"#;
    let plain = image(shapes);
    let merged = image(
        &shapes
            .replacen("<shape", "<shape type=\"merge\">\n<shape", 1)
            .replace(
                "<shape type=\"sphere\">",
                "</shape>\n<shape type=\"sphere\">",
            ),
    );
    assert_eq!(plain, merged, "a merge changed the image");
    let with_bsdf = format!(
        r#"{}<shape type="merge"><bsdf type="conductor"/>
<shape type="disk"/></shape>"#,
        ""
    );
    let loaded = load_scene_str(&scene(&with_bsdf), Path::new("m.xml"), &[]).unwrap();
    assert!(
        loaded
            .warnings
            .iter()
            .any(|w| w.contains("a <bsdf> in a merge shape is ignored")),
        "{:?}",
        loaded.warnings
    );
    let moved = scene(
        r#"<shape type="merge"><transform name="to_world"><translate x="1"/></transform>
<shape type="disk"/></shape>"#,
    );
    let e = match load_scene_str(&moved, Path::new("m.xml"), &[]) {
        Ok(_) => panic!("a merge with to_world loaded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("m.xml:9") && e.contains("to_world"), "{e}");
}

/// The `volume` texture reads its volume at the hit's world point: a
/// diffuse plane under a uniform sky of 1 whose reflectance is a 2-voxel
/// ramp (0.2, 0.8) over x ∈ [−1, 1] reflects the ramp's trilinear value,
/// clamped past the voxel centres (Mitsuba 3.9.1: 0.2006, 0.4998, 0.6508
/// at the three points below).
#[test]
fn volume_texture_reads_the_volume_at_the_hit() {
    let dir = common::scratch_dir("voltex");
    common::write_vol(&dir.join("ramp.vol"), [2, 1, 1], 1, &[0.2, 0.8]);
    let reading = |x: f32| -> (f64, f64) {
        let xml = format!(
            r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="2"/></integrator>
<sensor type="radiancemeter"><point name="origin" value="{x}, 0, 1"/><vector name="direction" value="0, 0, -1"/>
  <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="1"/><rfilter type="box"/></film>
</sensor>
<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
<shape type="rectangle"><bsdf type="diffuse">
  <texture type="volume" name="reflectance">
    <volume type="gridvolume" name="volume">
      <string name="filename" value="ramp.vol"/>
      <transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform>
    </volume>
  </texture>
</bsdf></shape>
</scene>"#
        );
        let loaded =
            load_scene_str(&xml, &dir.join("voltex.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
        let out = render(
            &loaded.scene,
            loaded.integrator.as_ref(),
            &RenderSettings { spp: 4096, seed: 1 },
            &|_| {},
        );
        let (mean, se) = common::pixel_mean_and_error(&out.image.data, 1);
        (mean, se.max(1e-6))
    };
    for (x, expected) in [(-0.75, 0.2), (0.0, 0.5), (0.25, 0.65)] {
        let (mean, se) = reading(x);
        let z = (mean - expected) / se;
        assert!(z.abs() < 4.0, "x = {x}: {mean} ± {se}, expected {expected}");
    }
    // The volume must be one: a colour is refused at its line.
    let xml = r#"<scene version="3.0.0"><texture type="volume" id="t">
  <rgb name="volume" value="0.5"/>
</texture></scene>"#;
    let e = match load_scene_str(xml, &dir.join("bad.xml"), &[]) {
        Ok(_) => panic!("a colour volume loaded"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("bad.xml:1") && e.contains("needs a nested volume"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A binary PLY of one Gaussian per row of `rows`, float properties
/// `names`, its last `truncate` bytes cut, written to `dir/name`.
fn gaussians_ply(
    dir: &Path,
    name: &str,
    names: &[&str],
    rows: &[Vec<f32>],
    truncate: usize,
) -> String {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n{}end_header\n",
        rows.len(),
        names
            .iter()
            .map(|n| format!("property float {n}\n"))
            .collect::<String>()
    )
    .into_bytes();
    for r in rows {
        for v in r {
            bytes.extend(v.to_le_bytes());
        }
    }
    bytes.truncate(bytes.len() - truncate);
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path.display().to_string()
}

const GAUSSIAN: [&str; 13] = [
    "x", "y", "z", "nx", "ny", "nz", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2",
    "rot_3",
];

/// Bad Gaussian files and parameters are refused with the file, the line
/// and what is wrong; a Gaussian scene loads and sees its ellipsoid.
#[test]
fn ellipsoids_refuse_bad_files_at_their_line() {
    let dir = common::scratch_dir("ellipsoids");
    let one = vec![
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, -1.0, -1.0, 1.0, 0.0, 0.0, 0.0,
    ];
    let good = gaussians_ply(&dir, "good.ply", &GAUSSIAN, std::slice::from_ref(&one), 0);
    let shape = |plugin: &str, file: &str, extra: &str| {
        format!(r#"<shape type="{plugin}"><string name="filename" value="{file}"/>{extra}</shape>"#)
    };
    let error = |body: &str| match load_scene_str(&scene(body), Path::new("bad.xml"), &[]) {
        Ok(_) => panic!("{body} loaded"),
        Err(e) => e.to_string(),
    };
    for plugin in ["ellipsoids", "ellipsoidsmesh"] {
        assert!(
            load_scene_str(&scene(&shape(plugin, &good, "")), Path::new("ok.xml"), &[]).is_ok()
        );
        let mut swapped = GAUSSIAN;
        swapped.swap(6, 9);
        let order = gaussians_ply(&dir, "order.ply", &swapped, std::slice::from_ref(&one), 0);
        let e = error(&shape(plugin, &order, ""));
        assert!(
            e.contains("bad.xml:")
                && e.contains("order.ply")
                && e.contains("must begin with x y z nx ny nz"),
            "{e}"
        );
        let cut = gaussians_ply(&dir, "cut.ply", &GAUSSIAN, &[one.clone(), one.clone()], 10);
        let e = error(&shape(plugin, &cut, ""));
        assert!(
            e.contains("bad.xml:") && e.contains("cut.ply") && e.contains("truncated"),
            "{e}"
        );
        let e = error(&shape(plugin, "missing.ply", ""));
        assert!(e.contains("missing.ply"), "{e}");
        let e = error(&format!(
            r#"<shape type="{plugin}"><string name="filename" value="{good}"/><emitter type="area"/></shape>"#
        ));
        assert!(e.contains("cannot carry an area emitter"), "{e}");
    }
    let e = error(&shape(
        "ellipsoidsmesh",
        &good,
        r#"<string name="shell" value="cube"/>"#,
    ));
    assert!(
        e.contains("bad.xml:") && e.contains("shell 'cube' is not one of"),
        "{e}"
    );
    // Not a float: Mitsuba would read its bytes as floats.
    let mut text = std::fs::read(&good).unwrap();
    let at = text
        .windows(16)
        .position(|w| w == b"property float x")
        .unwrap();
    text.splice(at..at + 16, b"property double x".iter().copied());
    std::fs::write(dir.join("double.ply"), text).unwrap();
    let e = error(&shape(
        "ellipsoids",
        &dir.join("double.ply").display().to_string(),
        "",
    ));
    assert!(
        e.contains("double.ply") && e.contains("property 'x'"),
        "{e}"
    );
}

/// A `measured` BSDF's bad file is refused at its line, naming the file
/// and what is wrong.
#[test]
fn measured_refuses_bad_files_at_their_line() {
    let dir = common::scratch_dir("measured");
    let good =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/parity/measured/ggx_iso.bsdf");
    let bytes = std::fs::read(&good).unwrap();
    std::fs::write(dir.join("cut.bsdf"), &bytes[..bytes.len() / 2]).unwrap();
    let body = |file: &str| {
        format!(
            r#"<shape type="sphere"><bsdf type="measured"><string name="filename" value="{file}"/></bsdf></shape>"#
        )
    };
    let error = |file: &str| match load_scene_str(&scene(&body(file)), Path::new("bad.xml"), &[]) {
        Ok(_) => panic!("{file} loaded"),
        Err(e) => e.to_string(),
    };
    assert!(load_scene_str(
        &scene(&body(&good.display().to_string())),
        Path::new("ok.xml"),
        &[]
    )
    .is_ok());
    let e = error(&dir.join("cut.bsdf").display().to_string());
    assert!(
        e.contains("bad.xml:") && e.contains("cut.bsdf") && e.contains("truncated"),
        "{e}"
    );
    let e = error("missing.bsdf");
    assert!(e.contains("bad.xml:") && e.contains("missing.bsdf"), "{e}");
}

/// A `sunsky` date or time that does not exist is refused at its line
/// (Mitsuba rolls it over into the next month or day).
#[test]
fn sunsky_refuses_dates_that_do_not_exist() {
    let body = |extra: &str| format!(r#"<emitter type="sunsky">{extra}</emitter>"#);
    let error = |extra: &str| match load_scene_str(&scene(&body(extra)), Path::new("sky.xml"), &[])
    {
        Ok(_) => panic!("{extra} loaded"),
        Err(e) => e.to_string(),
    };
    assert!(load_scene_str(&scene(&body("")), Path::new("ok.xml"), &[]).is_ok());
    let e = error(r#"<integer name="month" value="2"/><integer name="day" value="30"/>"#);
    assert!(e.contains("sky.xml:") && e.contains("no day 30"), "{e}");
    let e = error(r#"<float name="hour" value="24.5"/>"#);
    assert!(e.contains("sky.xml:") && e.contains("no hour 24.5"), "{e}");
}

/// A bad curve file is refused at its line in the scene, naming the file
/// and its own line.
#[test]
fn curves_refuse_bad_files_at_their_line() {
    let dir = common::scratch_dir("curves");
    let error_of = |plugin: &str, text: &str| {
        let file = dir.join("bad.txt");
        std::fs::write(&file, text).unwrap();
        let body = format!(
            r#"<shape type="{plugin}"><string name="filename" value="{}"/></shape>"#,
            file.display()
        );
        match load_scene_str(&scene(&body), Path::new("curves.xml"), &[]) {
            Ok(_) => panic!("{text:?} loaded"),
            Err(e) => e.to_string(),
        }
    };
    let error = |text: &str| error_of("linearcurve", text);
    let e = error("0 0 0 0.1\n1 0 0\n");
    assert!(
        e.contains("curves.xml:") && e.contains("bad.txt: line 2"),
        "{e}"
    );
    let e = error_of("bsplinecurve", "0 0 0 0.1\n1 0 0 0.1\n2 0 0 0.1\n");
    assert!(
        e.contains("curves.xml:") && e.contains("at least 4 control points"),
        "{e}"
    );
    let e = error("0 0 0 0.1\n");
    assert!(e.contains("at least 2 control points"), "{e}");
    let e = error("");
    assert!(e.contains("no control points"), "{e}");
}

/// `hair`'s bad parameters are refused at their line.
#[test]
fn hair_refuses_bad_parameters_at_their_line() {
    let error = |bsdf: &str| {
        let body = format!(r#"<shape type="sphere"><bsdf type="hair">{bsdf}</bsdf></shape>"#);
        match load_scene_str(&scene(&body), Path::new("hair.xml"), &[]) {
            Ok(_) => panic!("{bsdf} loaded"),
            Err(e) => e.to_string(),
        }
    };
    let e =
        error(r#"<float name="eumelanin" value="1"/><rgb name="sigma_a" value="0.2, 0.3, 0.4"/>"#);
    assert!(e.contains("hair.xml:") && e.contains("not both"), "{e}");
    let e = error(r#"<float name="longitudinal_roughness" value="1.5"/>"#);
    assert!(
        e.contains("longitudinal_roughness") && e.contains("[0, 1]"),
        "{e}"
    );
    let e = error(r#"<float name="int_ior" value="1.000277"/>"#);
    assert!(e.contains("differ"), "{e}");
}
