//! Participating media rendered by `volpath`, checked against what must
//! hold whatever the reference renderer:
//!
//! - a furnace: a sphere of index-matched (`null`-bounded), non-absorbing
//!   medium in a constant environment renders as the environment, for
//!   grey and chromatic, homogeneous and heterogeneous media and
//!   anisotropic phase functions;
//! - seed 003's validation: a voxel grid of constant density inside a
//!   `null` sphere renders like the homogeneous medium (delta and ratio
//!   tracking over majorant grids against exact sampling);
//! - an emissive, purely absorbing slab of known thickness glows with
//!   L_e (1 − e^(−σ_a d));
//! - binary and generalized shadow rays through a masked sphere converge to
//!   the same image, and the generalized ones with less variance.

mod common;

use common::{assert_same_image, render_statistics};

const SIZE: u32 = 12;

fn scene(integrator: &str, body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
{integrator}
<sensor type="perspective">
  <float name="fov" value="50"/>
  <transform name="to_world"><lookat origin="0, 0.5, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="{SIZE}"/><integer name="height" value="{SIZE}"/>
    <rfilter type="box"/></film>
</sensor>
{body}
</scene>"#
    )
}

const VOLPATH: &str = r#"<integrator type="volpath"/>"#;

/// Asserts every pixel's mean (over `k` renders) is `value` within 6
/// standard errors, and the image mean within 4.
fn assert_uniform(xml: &str, spp: u32, k: u32, value: f64, label: &str) {
    let (mean, var) = render_statistics(xml, spp, k);
    let mut worst = (0.0f64, 0);
    for i in 0..mean.len() {
        let se = (var[i] / k as f64).sqrt().max(1e-6);
        let t = (mean[i] - value).abs() / se;
        if t > worst.0 {
            worst = (t, i);
        }
    }
    assert!(
        worst.0 < 6.0,
        "{label}: pixel {} channel {}: {} instead of {value} (t = {:.1})",
        worst.1 / 3,
        worst.1 % 3,
        mean[worst.1],
        worst.0
    );
    let n = mean.len() as f64;
    let m = mean.iter().sum::<f64>() / n;
    let se = (var.iter().sum::<f64>() / k as f64).sqrt() / n;
    assert!(
        (m - value).abs() < 4.0 * se.max(1e-7),
        "{label}: image mean {m} instead of {value} (± {se})"
    );
}

fn furnace(medium: &str) -> String {
    scene(
        VOLPATH,
        &format!(
            r#"<emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
{medium}
<shape type="sphere"><float name="radius" value="1.2"/><bsdf type="null"/><ref id="m" name="interior"/></shape>"#
        ),
    )
}

/// Media of albedo 1 inside a null sphere under a constant sky of 0.5:
/// every pixel is 0.5 (the sphere fills most of the frame).
#[test]
fn furnace_index_matched_media_render_as_the_environment() {
    let media = [
        (
            "grey homogeneous, hg 0.6",
            r#"<medium type="homogeneous" id="m"><float name="sigma_t" value="2"/><float name="albedo" value="1"/>
  <phase type="hg"><float name="g" value="0.6"/></phase></medium>"#,
        ),
        (
            "chromatic homogeneous, hg -0.4",
            r#"<medium type="homogeneous" id="m"><rgb name="sigma_t" value="0.3, 1.5, 5"/><float name="albedo" value="1"/>
  <phase type="hg"><float name="g" value="-0.4"/></phase></medium>"#,
        ),
        (
            "chromatic heterogeneous (pyroclastic), rayleigh",
            r#"<medium type="heterogeneous" id="m"><float name="albedo" value="1"/><float name="scale" value="4"/>
  <volume type="pyroclastic" name="sigma_t"><float name="radius" value="0.8"/><float name="amplitude" value="0.3"/></volume>
  <phase type="rayleigh"/></medium>"#,
        ),
        (
            "chromatic heterogeneous (constant)",
            r#"<medium type="heterogeneous" id="m"><float name="albedo" value="1"/>
  <volume type="constvolume" name="sigma_t"><rgb name="value" value="2, 0.5, 1"/></volume></medium>"#,
        ),
    ];
    for (label, medium) in media {
        assert_uniform(&furnace(medium), 32, 32, 0.5, label);
    }
}

/// The furnace can fail: an albedo of 0.97 darkens the sphere.
#[test]
fn furnace_sees_absorption() {
    let medium = r#"<medium type="homogeneous" id="m"><float name="sigma_t" value="2"/><float name="albedo" value="0.97"/></medium>"#;
    let result =
        std::panic::catch_unwind(|| assert_uniform(&furnace(medium), 32, 8, 0.5, "albedo 0.97"));
    assert!(result.is_err(), "an absorbing medium passed the furnace");
}

/// Writes a `.vol` grid of `n`³ voxels over [−h, h]³ holding density 1
/// within radius `r` of the centre (at voxel centres) and 0 outside.
fn write_sphere_grid(path: &std::path::Path, n: i32, h: f32, r: f32) {
    let mut b = b"VOL".to_vec();
    b.push(3);
    b.extend(1i32.to_le_bytes());
    for _ in 0..3 {
        b.extend(n.to_le_bytes());
    }
    b.extend(1i32.to_le_bytes());
    for v in [-h, -h, -h, h, h, h] {
        b.extend(v.to_le_bytes());
    }
    let centre = |i: i32| -h + (i as f32 + 0.5) * 2.0 * h / n as f32;
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let d = (centre(x).powi(2) + centre(y).powi(2) + centre(z).powi(2)).sqrt();
                b.extend(if d <= r { 1.0f32 } else { 0.0 }.to_le_bytes());
            }
        }
    }
    std::fs::write(path, b).unwrap();
}

/// The sphere of `medium` against a sky, with a sun-like point light:
/// pixels through it see the sky attenuated and in-scattered light.
fn lit_sphere(medium: &str) -> String {
    scene(
        VOLPATH,
        &format!(
            r#"<emitter type="point"><point name="position" value="2, 3, 2"/><rgb name="intensity" value="4"/></emitter>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
{medium}
<shape type="sphere"><float name="radius" value="1.1"/><bsdf type="null"/><ref id="m" name="interior"/></shape>"#
        ),
    )
}

/// The extinction of the sphere (optical radius 1.1: much of the light
/// crosses it).
const SIGMA: f32 = 1.0;
/// The same through the grid (5 % more fails the test).
const GRID_SIGMA: f32 = SIGMA;

/// Seed 003: a heterogeneous grid holding a solid sphere of constant
/// density (larger than the null sphere that bounds the medium, so that
/// the trilinear lookups inside are exactly 1) renders like the
/// homogeneous medium of that density — with a majorant grid and with one
/// majorant for the whole grid.
#[test]
fn grid_sphere_equals_homogeneous_sphere() {
    let dir = std::env::temp_dir().join(format!("yubin-media-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vol = dir.join("sphere.vol");
    // Voxels 0.15 wide: lookups within 1.1 + 0.15·√3 of the centre read
    // only voxel centres within 1.4.
    write_sphere_grid(&vol, 20, 1.5, 1.4);
    let albedo = r#"<rgb name="albedo" value="0.9, 0.6, 0.3"/><phase type="hg"><float name="g" value="0.3"/></phase>"#;
    let homogeneous = lit_sphere(&format!(
        r#"<medium type="homogeneous" id="m"><float name="sigma_t" value="{SIGMA}"/>{albedo}</medium>"#
    ));
    for factor in [4, 0] {
        let grid = lit_sphere(&format!(
            r#"<medium type="heterogeneous" id="m"><float name="scale" value="{GRID_SIGMA}"/>{albedo}
  <integer name="majorant_resolution_factor" value="{factor}"/>
  <volume type="gridvolume" name="sigma_t"><boolean name="use_grid_bbox" value="true"/>
    <string name="filename" value="{}"/></volume></medium>"#,
            vol.display()
        ));
        assert_same_image(&grid, &homogeneous, 64, 16, &format!("factor {factor}"));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A purely absorbing, emissive slab seen face-on: L_e (1 − e^(−σ_a d))
/// per channel, homogeneous and heterogeneous.
#[test]
fn emissive_slab_glows_by_its_optical_depth() {
    let (sigma, le, d) = ([0.5f64, 1.0, 3.0], [2.0f64, 1.0, 0.5], 0.6f64);
    let medium = |kind: &str| {
        let sigma_t = if kind == "homogeneous" {
            r#"<rgb name="sigma_t" value="0.5, 1, 3"/>"#.to_string()
        } else {
            // A constvolume fills the unit cube through its to_world.
            r#"<volume type="constvolume" name="sigma_t"><rgb name="value" value="0.5, 1, 3"/>
  <transform name="to_world"><scale value="20"/><translate value="-10, -10, -10"/></transform></volume>"#.to_string()
        };
        format!(
            r#"<medium type="{kind}" id="m">{sigma_t}<float name="albedo" value="0"/>
  <rgb name="radiance" value="2, 1, 0.5"/></medium>
<shape type="cube"><transform name="to_world"><scale x="10" y="10" z="0.3"/></transform>
  <bsdf type="null"/><ref id="m" name="interior"/></shape>"#
        )
    };
    for kind in ["homogeneous", "heterogeneous"] {
        let xml = scene(r#"<integrator type="volpath"/>"#, &medium(kind))
            .replace(r#"origin="0, 0.5, 4""#, r#"origin="0, 0, 4""#)
            .replace(
                r#"<float name="fov" value="50"/>"#,
                r#"<float name="fov" value="1"/>"#,
            );
        let (mean, var) = render_statistics(&xml, 16, 4);
        for c in 0..3 {
            let want = le[c] * (1.0 - (-sigma[c] * d).exp());
            let n = (mean.len() / 3) as f64;
            let m = mean.iter().skip(c).step_by(3).sum::<f64>() / n;
            let se = (var.iter().skip(c).step_by(3).sum::<f64>() / 4.0).sqrt() / n;
            assert!(
                (m - want).abs() < 4.0 * se + 1e-4,
                "{kind}, channel {c}: {m} instead of {want} (± {se})"
            );
        }
    }
}

fn masked(shadow_rays: &str) -> String {
    scene(
        &format!(
            r#"<integrator type="volpath"><string name="shadow_rays" value="{shadow_rays}"/></integrator>"#
        ),
        r#"<shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate y="2"/></transform>
  <emitter type="area"><rgb name="radiance" value="10"/></emitter></shape>
<shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/><translate y="-0.8"/></transform>
  <bsdf type="diffuse"/></shape>
<shape type="sphere"><float name="radius" value="0.6"/><point name="center" value="0, 0.3, 0"/>
  <bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.4, 0.2"/></bsdf></bsdf></shape>"#,
    )
}

/// Seed 003: shadow rays that stop at the masked sphere (binary) and ones
/// that pass through it with weight 1 − opacity (generalized) converge to
/// the same image; the generalized ones have lower variance at equal
/// samples.
#[test]
fn binary_and_generalized_shadow_rays_agree() {
    let (binary, generalized) = (masked("binary"), masked("generalized"));
    assert_same_image(&binary, &generalized, 16, 16, "binary vs generalized");
    let total = |xml: &str| render_statistics(xml, 16, 16).1.iter().sum::<f64>();
    let (vb, vg) = (total(&binary), total(&generalized));
    println!(
        "summed pixel variance: binary {vb:.4}, generalized {vg:.4}, ratio {:.2}",
        vb / vg
    );
    assert!(vg < vb, "generalized {vg} vs binary {vb}");
}

/// `volpathmis` (MIS over whole-path densities: free flights, null
/// collisions, null lobes) converges to `volpath`'s images: a chromatic
/// heterogeneous cloud, a chromatic homogeneous sphere in a glass-free
/// null boundary, and light through a masked sphere.
#[test]
fn volpathmis_renders_what_volpath_renders() {
    let media = [
        r#"<medium type="heterogeneous" id="m"><rgb name="albedo" value="0.9, 0.7, 0.95"/><float name="scale" value="3"/>
  <volume type="pyroclastic" name="sigma_t"><float name="radius" value="0.8"/></volume>
  <phase type="hg"><float name="g" value="0.5"/></phase></medium>"#,
        r#"<medium type="homogeneous" id="m"><rgb name="sigma_t" value="0.4, 1.2, 3"/><rgb name="albedo" value="0.8, 0.9, 0.6"/></medium>"#,
    ];
    for medium in media {
        let volpath = lit_sphere(medium);
        let mis = volpath.replace(
            r#"<integrator type="volpath"/>"#,
            r#"<integrator type="volpathmis"/>"#,
        );
        assert!(mis.contains("volpathmis"));
        assert_same_image(&volpath, &mis, 32, 16, "volpathmis vs volpath");
    }
    // A floor lit through a masked sheet by a wide light, which paths
    // through the sheet find as often as light sampling does.
    let sheet = |integrator: &str| {
        scene(
            &format!(r#"<integrator type="{integrator}"/>"#),
            r#"<shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="90"/><translate y="2"/></transform>
  <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
<shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="1"/></transform>
  <bsdf type="mask"><float name="opacity" value="0.7"/><bsdf type="diffuse"/></bsdf></shape>
<shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/><translate y="-0.8"/></transform>
  <bsdf type="diffuse"/></shape>"#,
        )
    };
    assert_same_image(
        &sheet("volpath"),
        &sheet("volpathmis"),
        32,
        16,
        "masked sheet, volpathmis",
    );
}

/// Mitsuba 3.9.1's heterogeneous medium with a constant extinction fills
/// only its constvolume's box, the unit cube [0, 1]³ (through the
/// volume's `to_world`): in a cube [−1, 1]³ of σ_t = 1, a ray along z at
/// x = y = 0.5 crosses 1 unit of it (Mitsuba: 0.3684 at 4096 spp), one at
/// x = y = −0.5 none (Mitsuba: 1).
#[test]
fn constant_heterogeneous_extinction_fills_the_unit_cube_as_in_mitsuba() {
    let reading = |at: &str, sigma_t: &str| {
        let xml = format!(
            r#"<scene version="3.0.0">
<integrator type="volpath"/>
<sensor type="radiancemeter"><point name="origin" value="{at}, -5"/><vector name="direction" value="0, 0, 1"/>
  <film type="hdrfilm"><integer name="width" value="1"/><integer name="height" value="1"/><rfilter type="box"/></film></sensor>
<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
<shape type="cube"><bsdf type="null"/>
  <medium type="heterogeneous" name="interior">{sigma_t}<float name="albedo" value="0"/></medium></shape>
</scene>"#
        );
        let (mean, _) = render_statistics(&xml, 4096, 1);
        mean[0]
    };
    let plain = r#"<float name="sigma_t" value="1"/>"#;
    let inside = reading("0.5, 0.5", plain);
    assert!((inside - (-1.0f64).exp()).abs() < 0.03, "{inside}");
    assert_eq!(reading("-0.5, -0.5", plain), 1.0);
    let moved = r#"<volume type="constvolume" name="sigma_t"><float name="value" value="1"/>
        <transform name="to_world"><translate value="-1, -1, -1"/></transform></volume>"#;
    let moved = reading("-0.5, -0.5", moved);
    assert!((moved - (-1.0f64).exp()).abs() < 0.03, "{moved}");
}
