//! Portals between worlds: a room seen and lit through a portal renders
//! as the same room behind an open window (per-pixel Welch tests over
//! independent renders, with and without next-event estimation of its
//! lamp, and with the noise of the window's when light samples reach the
//! lamp through the portal), a point light outside lights the room
//! through the portal (light samples alone can), and bad portals are
//! refused with their line.

mod common;

use common::{render_images_from, statistics};
use std::path::Path;
use yubin_scene::load_scene_str;

/// The camera, film and integrator around `body`.
fn scene(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="5"/><string name="light_sampler" value="uniform"/></integrator>
<sensor type="perspective"><float name="fov" value="50"/>
  <transform name="to_world"><lookat origin="0.3, -3, 1.1" target="0, 1, 0.8" up="0, 0, 1"/></transform>
  <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="18"/><rfilter type="box"/></film>
</sensor>
<bsdf type="twosided" id="wall"><bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></bsdf>
{body}
</scene>"#
    )
}

/// A rectangle spanning x0..x1 and z0..z1 in the plane y (facing ±y).
fn front(x0: f32, x1: f32, z0: f32, z1: f32, dx: f32, extra: &str) -> String {
    let (sx, sz) = ((x1 - x0) / 2.0, (z1 - z0) / 2.0);
    let (cx, cz) = ((x0 + x1) / 2.0 + dx, (z0 + z1) / 2.0);
    format!(
        r#"<shape type="rectangle"><transform name="to_world"><scale x="{sx}" y="{sz}"/><rotate x="1" angle="90"/><translate x="{cx}" z="{cz}"/></transform>{extra}</shape>"#
    )
}

/// The front wall around the window (x −0.4…0.4, z 0.7…1.3), moved by dx.
fn front_wall(dx: f32) -> String {
    let w = r#"<ref id="wall"/>"#;
    [
        front(-1.0, -0.4, 0.0, 2.0, dx, w),
        front(0.4, 1.0, 0.0, 2.0, dx, w),
        front(-0.4, 0.4, 0.0, 0.7, dx, w),
        front(-0.4, 0.4, 1.3, 2.0, dx, w),
    ]
    .concat()
}

/// The room behind the front wall (x −1…1, y 0…2, z 0…2) with a red ball
/// and a lamp (`lamp_weight` its sampling weight), moved by dx.
fn room(dx: f32, lamp_weight: f32) -> String {
    let wall = |t: &str| {
        format!(
            r#"<shape type="rectangle"><transform name="to_world">{t}<translate x="{dx}"/></transform><ref id="wall"/></shape>"#
        )
    };
    [
        wall(r#"<translate y="1"/>"#),
        wall(r#"<translate y="1" z="2"/>"#),
        wall(r#"<rotate x="1" angle="90"/><translate y="2" z="1"/>"#),
        wall(r#"<rotate y="1" angle="90"/><translate x="-1" y="1" z="1"/>"#),
        wall(r#"<rotate y="1" angle="90"/><translate x="1" y="1" z="1"/>"#),
        format!(r#"<shape type="sphere"><point name="center" x="{}" y="1.2" z="0.4"/><float name="radius" value="0.4"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.1"/></bsdf></shape>"#, 0.3 + dx),
        format!(r#"<shape type="sphere"><point name="center" x="{}" y="1.5" z="1.6"/><float name="radius" value="0.15"/>
            <emitter type="area"><rgb name="radiance" value="40"/><float name="sampling_weight" value="{lamp_weight}"/></emitter></shape>"#, -0.5 + dx),
    ]
    .concat()
        + &front_wall(dx)
}

/// The ground outside, where light from the room falls through the
/// window, and a faint point light far above it, which takes the light
/// samples when the lamp's sampling weight is 0 (weights are relative;
/// the scenes choose lights by weight alone, `light_sampler` `uniform`).
const GROUND: &str = r#"<shape type="rectangle"><transform name="to_world"><scale x="3" y="2"/><translate y="-2"/></transform><ref id="wall"/></shape>
<emitter type="point"><point name="position" value="0, -30, 40"/><rgb name="intensity" value="0.001"/></emitter>"#;

/// The room behind an open window in one world, with or without the
/// ground outside.
fn window(lamp_weight: f32, ground: bool) -> String {
    let ground = if ground { GROUND } else { "" };
    scene(&format!("{ground}{}", room(0.0, lamp_weight)))
}

/// The room in a world of its own, 50 units away, seen through a portal
/// in the window of a front wall of the camera's world; `there_dx` moves
/// the far side (0: where the room's window is).
fn portal(lamp_weight: f32, there_dx: f32, ground: bool) -> String {
    let ground = if ground { GROUND } else { "" };
    let side = |name: &str, dx: f32| {
        front(-0.4, 0.4, 0.7, 1.3, dx, "").replace(
            r#"<shape type="rectangle">"#,
            &format!(r#"<shape type="rectangle" name="{name}">"#),
        )
    };
    scene(&format!(
        r#"{ground}{}
        <shape type="portal"><string name="to" value="room"/>{}{}</shape>
        <world id="room">{}</world>"#,
        front_wall(0.0),
        side("here", 0.0),
        side("there", 50.0 + there_dx),
        room(50.0, lamp_weight)
    ))
}

/// How two scenes' renders compare.
struct Comparison {
    /// The worst per-pixel Welch t.
    worst_t: f64,
    /// The z of the image sums (one sum per render: its pixels and
    /// channels are correlated, their variances do not add).
    z: f64,
    /// The variances of one render's image sum, per scene.
    variances: (f64, f64),
}

/// Compares `k` renders of each scene at `spp`.
fn compare(a: &str, b: &str, spp: u32, k: u32) -> Comparison {
    let (images_a, images_b) = (
        render_images_from(a, spp, k, 0),
        render_images_from(b, spp, k, 1000),
    );
    let ((ma, va), (mb, vb)) = (statistics(&images_a), statistics(&images_b));
    let t = |i: usize| (ma[i] - mb[i]).abs() / ((va[i] + vb[i]) / k as f64).sqrt().max(1e-6);
    let at = (0..ma.len())
        .max_by(|x, y| t(*x).total_cmp(&t(*y)))
        .unwrap_or(0);
    let worst_t = t(at);
    println!(
        "worst at pixel {} channel {}: {:.4} ± {:.4} vs {:.4} ± {:.4}",
        at / 3,
        at % 3,
        ma[at],
        (va[at] / k as f64).sqrt(),
        mb[at],
        (vb[at] / k as f64).sqrt()
    );
    let sums = |images: &[Vec<f32>]| -> Vec<Vec<f32>> {
        images
            .iter()
            .map(|im| vec![im.iter().sum::<f32>()])
            .collect()
    };
    let ((sa, sva), (sb, svb)) = (statistics(&sums(&images_a)), statistics(&sums(&images_b)));
    let z = (sa[0] - sb[0]).abs() / ((sva[0] + svb[0]) / k as f64).sqrt();
    println!(
        "sums {:.4} and {:.4}, variances {:.3e} and {:.3e}",
        sa[0], sb[0], sva[0], svb[0]
    );
    assert!(sa[0] > 0.0 && sb[0] > 0.0, "black images");
    Comparison {
        worst_t,
        z,
        variances: (sva[0], svb[0]),
    }
}

/// What the camera sees through the portal: the room as through the
/// window, pixel by pixel (its lamp lights the room by next-event
/// estimation in both).
#[test]
fn a_room_through_a_portal_looks_as_behind_a_window() {
    let c = compare(&window(1.0, false), &portal(1.0, 0.0, false), 64, 16);
    println!(
        "through the portal: worst t {:.2}, sum z {:.2}",
        c.worst_t, c.z
    );
    assert!(c.worst_t < 7.0 && c.z < 4.0, "t {}, z {}", c.worst_t, c.z);
    // The test can tell: the far side 5 cm off shows another part of the room.
    let c = compare(&window(1.0, false), &portal(1.0, 0.05, false), 64, 16);
    println!("far side moved: worst t {:.2}, sum z {:.2}", c.worst_t, c.z);
    assert!(
        c.worst_t > 7.0 || c.z > 4.0,
        "a misplaced portal passes: t {}, z {}",
        c.worst_t,
        c.z
    );
}

/// Light from the room's lamp falls through the portal onto the ground of
/// the camera's world, and comes back in: the image converges to the
/// window's, with the lamp sampled by next-event estimation through the
/// portal (pixel by pixel, and with the window's noise: light samples
/// find the lamp as often as through the window) and not (BSDF samples
/// alone, whose rare hits make single pixels heavy-tailed at this sample
/// count: the image's sum over 16 renders of 512 spp is compared). A lamp
/// 10 % brighter behind the portal fails.
#[test]
fn light_through_a_portal_lights_the_other_world() {
    let c = compare(&window(1.0, true), &portal(1.0, 0.0, true), 512, 16);
    println!(
        "lamp light-sampled: worst t {:.2}, sum z {:.2}",
        c.worst_t, c.z
    );
    assert!(c.worst_t < 7.0 && c.z < 4.0, "t {}, z {}", c.worst_t, c.z);
    let (window_var, portal_var) = c.variances;
    assert!(
        portal_var < 1.3 * window_var,
        "noisier through the portal: variances {window_var} and {portal_var}"
    );
    let c = compare(&window(0.0, true), &portal(0.0, 0.0, true), 512, 16);
    println!("lamp by BSDF samples alone: sum z {:.2}", c.z);
    assert!(c.z < 4.0, "z {}", c.z);
    let brighter = portal(1.0, 0.0, true).replace(r#"value="40""#, r#"value="44""#);
    let c = compare(&window(1.0, true), &brighter, 512, 16);
    println!("lamp 10 % brighter: sum z {:.2}", c.z);
    assert!(c.z > 4.0, "a brighter lamp passes: z {}", c.z);
}

/// A point light outside shines through the window onto the room's
/// floor: through the portal, light samples alone can bring it in (BSDF
/// samples never find a point), looking from the room's world back
/// through the portal's far side. Without them the room stays dark, and
/// the test fails.
#[test]
fn a_point_light_shines_through_a_portal() {
    let lit = |xml: String| {
        xml.replace(
            r#"<rgb name="radiance" value="40"/>"#,
            r#"<rgb name="radiance" value="0.01"/>"#,
        )
        .replace(
            r#"<rgb name="intensity" value="0.001"/>"#,
            r#"<rgb name="intensity" value="2000"/>"#,
        )
    };
    let c = compare(
        &lit(window(1.0, true)),
        &lit(portal(1.0, 0.0, true)),
        64,
        16,
    );
    println!("point light: worst t {:.2}, sum z {:.2}", c.worst_t, c.z);
    assert!(c.worst_t < 7.0 && c.z < 4.0, "t {}, z {}", c.worst_t, c.z);
}

fn error_of(body: &str) -> String {
    match load_scene_str(&scene(body), Path::new("test.xml"), &[]) {
        Ok(_) => panic!("loaded: {body}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_portals_are_refused_with_their_line() {
    let rect = r#"<shape type="rectangle" name="here"/>"#;
    // The body starts on line 8.
    let e = error_of(&format!(
        "<world id=\"w\"/>\n<shape type=\"portal\"><string name=\"to\" value=\"v\"/>{rect}<shape type=\"rectangle\" name=\"there\"/></shape>"
    ));
    assert!(
        e.contains("test.xml:9") && e.contains("no <world id=\"v\">"),
        "{e}"
    );
    let e = error_of(&format!(
        "<world id=\"w\"/>\n<shape type=\"portal\"><string name=\"to\" value=\"w\"/>{rect}\n<shape type=\"disk\" name=\"there\"/></shape>"
    ));
    assert!(e.contains("test.xml:10") && e.contains("same shape"), "{e}");
    let e = error_of("<world>\n</world>");
    assert!(e.contains("test.xml:8") && e.contains("needs an id"), "{e}");
    let e = error_of(&format!(
        "<world id=\"w\"/>\n<shape type=\"portal\"><string name=\"to\" value=\"w\"/>{rect}</shape>"
    ));
    assert!(e.contains("test.xml:9") && e.contains("\"there\""), "{e}");
    let direct = scene(&format!(
        "<world id=\"w\"/><shape type=\"portal\"><string name=\"to\" value=\"w\"/>{rect}<shape type=\"rectangle\" name=\"there\"/></shape>"
    ))
    .replace(
        r#"<integrator type="path"><integer name="max_depth" value="5"/><string name="light_sampler" value="uniform"/></integrator>"#,
        r#"<integrator type="direct"/>"#,
    );
    let e = match load_scene_str(&direct, Path::new("test.xml"), &[]) {
        Ok(_) => panic!("a portal loaded under direct"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("path integrator"), "{e}");
    let e = error_of(&format!(
        "<world id=\"w\"/><shape type=\"portal\"><string name=\"to\" value=\"w\"/>{rect}<shape type=\"rectangle\" name=\"there\"/></shape>\n<shape type=\"sphere\"><bsdf type=\"null\"/></shape>"
    ));
    assert!(e.contains("do not yet combine with null"), "{e}");
}
