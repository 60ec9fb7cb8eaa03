//! Phase functions in a whole render, against single scattering computed
//! here: a `radiancemeter` looks along +x through a unit cube of
//! scattering medium (σt = 1, albedo 1) lit by a directional light, so
//! that with `volpath` at `max_depth` 2 the radiance is
//! ∫ e^−(s+1) p(θ) e^−d(s) ds over the ray's 2 units in the cube, d the
//! distance to the cube's side toward the light, θ the fixed scattering
//! angle (the scenes Mitsuba 3.9.1 renders to the same values:
//! `tabphase` 0.026802 ± 0.000026 for 0.026790 computed). The meter's film
//! is 1 × 16 pixels: 16 independent estimates give the standard error.

mod common;

use std::path::Path;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::load_scene_str;

/// The light travels along (0.6, 0, −0.8); the meter sees light leaving
/// along −x: cos θ = −0.6.
fn scene(phase: &str, film: (u32, u32)) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="volpath"><integer name="max_depth" value="2"/></integrator>
<sensor type="radiancemeter">
  <point name="origin" value="-5, 0, 0"/>
  <vector name="direction" value="1, 0, 0"/>
  <film type="hdrfilm"><integer name="width" value="{}"/><integer name="height" value="{}"/>
    <rfilter type="box"/></film>
</sensor>
<emitter type="directional">
  <vector name="direction" value="0.6, 0, -0.8"/>
  <rgb name="irradiance" value="1, 1, 1"/>
</emitter>
<shape type="cube">
  <bsdf type="null"/>
  <medium type="homogeneous" name="interior">
    <float name="sigma_t" value="1"/>
    <float name="albedo" value="1"/>
    {phase}
  </medium>
</shape>
</scene>"#,
        film.0, film.1
    )
}

/// ∫ e^−(s+1) e^−d(s) ds over s ∈ [−1, 1], d(s) = min(1.25, (s + 1)/0.6).
fn path_integral() -> f64 {
    path_integral_along(1.0, 1.0)
}

/// [`path_integral`] with the extinction `toward_meter` along x (also the
/// scattering coefficient there, albedo 1) and `toward_light` along the
/// light: ∫ σ e^−σ(s+1) e^−σ_l d(s) ds.
fn path_integral_along(toward_meter: f64, toward_light: f64) -> f64 {
    let n = 100_000;
    (0..n)
        .map(|i| {
            let s = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
            toward_meter
                * (-toward_meter * (s + 1.0)).exp()
                * (-toward_light * (1.25f64).min((s + 1.0) / 0.6)).exp()
                * 2.0
                / n as f64
        })
        .sum()
}

/// The z-score of the meter's reading for `phase` against p(θ) = `p`.
fn z_score(phase: &str, p: f64) -> f64 {
    z_score_of(&scene(phase, (1, 16)), path_integral() * p)
}

/// The z-score of the reading of the 1 × 16 meter in `xml` against
/// `expected`.
fn z_score_of(xml: &str, expected: f64) -> f64 {
    let loaded = load_scene_str(xml, Path::new("meter.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings {
            spp: 16_384,
            seed: 7,
        },
        &|_| {},
    );
    let (mean, se) = common::pixel_mean_and_error(&out.image.data, 0);
    (mean - expected) / se
}

const TAU: f64 = 2.0 * std::f64::consts::PI;

#[test]
fn tabphase_and_blendphase_scatter_as_computed() {
    // "1, 3, 2" at cos θ = −0.6: 1.8, over its integral 4.5, over 2π.
    let tab = 1.8 / 4.5 / TAU;
    let tabphase = r#"<phase type="tabphase"><string name="values" value="1, 3, 2"/></phase>"#;
    let z = z_score(tabphase, tab);
    assert!(z.abs() < 4.0, "tabphase: z = {z}");
    // Read the other way round (forward first), the same table is wrong.
    let z = z_score(tabphase, (1.0 + 0.4 * 1.0) / 4.5 / TAU);
    assert!(
        z.abs() > 6.0,
        "tabphase the wrong way round passes: z = {z}"
    );
    // A quarter of the second (the table), three quarters isotropic.
    let iso = 1.0 / (2.0 * TAU);
    let blend = r#"<phase type="blendphase"><float name="weight" value="0.25"/>
        <phase type="isotropic"/>
        <phase type="tabphase"><string name="values" value="1, 3, 2"/></phase></phase>"#;
    let z = z_score(blend, 0.75 * iso + 0.25 * tab);
    assert!(z.abs() < 4.0, "blendphase: z = {z}");
    let z = z_score(blend, 0.25 * iso + 0.75 * tab);
    assert!(
        z.abs() > 6.0,
        "blendphase with its parts swapped passes: z = {z}"
    );
    // Henyey–Greenstein through the same test, g = 0.5.
    let g: f64 = 0.5;
    let hg = (1.0 - g * g) / (2.0 * TAU * (1.0 + g * g - 2.0 * g * -0.6).powf(1.5));
    let z = z_score(
        r#"<phase type="hg"><float name="g" value="0.5"/></phase>"#,
        hg,
    );
    assert!(z.abs() < 4.0, "hg: z = {z}");
}

#[test]
fn bad_phase_tables_and_meters_are_refused_at_their_line() {
    let error = |phase: &str, film: (u32, u32)| match load_scene_str(
        &scene(phase, film),
        Path::new("bad.xml"),
        &[],
    ) {
        Ok(_) => panic!("{phase} loaded"),
        Err(e) => e.to_string(),
    };
    let one = error(
        r#"<phase type="tabphase"><string name="values" value="1"/></phase>"#,
        (1, 1),
    );
    assert!(
        one.contains("bad.xml:18") && one.contains("at least two"),
        "{one}"
    );
    let neg = error(
        r#"<phase type="tabphase"><string name="values" value="1, -2"/></phase>"#,
        (1, 1),
    );
    assert!(neg.contains("must not be negative"), "{neg}");
    let three = error(
        r#"<phase type="blendphase"><phase type="isotropic"/></phase>"#,
        (1, 1),
    );
    assert!(
        three.contains("exactly two nested phase functions, not 1"),
        "{three}"
    );
    let film = error(r#"<phase type="isotropic"/>"#, (2, 2));
    assert!(
        film.contains("bad.xml:3") && film.contains("must be 1 pixel wide or tall, not 2x2"),
        "{film}"
    );
}

/// σ_t = 1 over the cube [−1, 1]³ for a heterogeneous medium (whose
/// constant extinction fills only its constvolume's box, as Mitsuba's).
const COVERING_UNIT_EXTINCTION: &str = r#"<volume type="constvolume" name="sigma_t"><float name="value" value="1"/>
    <transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform></volume>"#;

/// An `sggx` phase function whose S (S_xx, S_yy, S_zz, S_xy, S_xz, S_yz)
/// is `voxels` (1 or 2 along x) written to a `.vol` file.
fn sggx_phase(name: &str, voxels: &[[f32; 6]]) -> String {
    let dir = common::scratch_dir("sggx");
    let file = dir.join(format!("{name}.vol"));
    common::write_vol(
        &file,
        [voxels.len() as i32, 1, 1],
        6,
        voxels.concat().as_slice(),
    );
    format!(
        r#"<phase type="sggx"><volume type="gridvolume" name="S">
            <string name="filename" value="{}"/></volume></phase>"#,
        file.display()
    )
}

/// `sggx` flakes S = diag(1, 1, 1/4) in the single-scattering scene: the
/// extinction is σ_t √(ωᵀSω) along each leg (1 toward the meter, √0.52
/// toward the light) and p = D(h) / 4σ(wo) (Mitsuba 3.9.1 reads 0.031360
/// ± 0.00004 here; this integral is 0.031327). As one matrix, and as a
/// two-voxel grid of the same matrix in a heterogeneous medium; extinction
/// left unscaled fails.
#[test]
fn sggx_scatters_and_attenuates_by_projected_area() {
    let flakes = [1.0, 1.0, 0.25, 0.0, 0.0, 0.0];
    // h = (−1.6, 0, 0.8)/|·|: hᵀS⁻¹h = 1.6, √det S = 0.5.
    let p = 1.0 / (std::f64::consts::PI * 0.5 * 1.6 * 1.6) / 4.0;
    let expected = path_integral_along(1.0, 0.52f64.sqrt()) * p;
    assert!((expected - 0.031327).abs() < 1e-5, "{expected}");
    let one = sggx_phase("flakes", &[flakes]);
    let z = z_score(&one, expected / path_integral());
    assert!(z.abs() < 4.0, "sggx: z = {z}");
    let unscaled = path_integral() * p;
    let z = z_score(&one, unscaled / path_integral());
    assert!(
        z.abs() > 6.0,
        "sggx without the projected area passes: z = {z}"
    );
    let grid = sggx_phase("flakes2", &[flakes, flakes]);
    let heterogeneous = scene(&grid, (1, 16)).replace(
        r#"<medium type="homogeneous" name="interior">
    <float name="sigma_t" value="1"/>"#,
        &format!(r#"<medium type="heterogeneous" name="interior">{COVERING_UNIT_EXTINCTION}"#),
    );
    let z = z_score_of(&heterogeneous, expected);
    assert!(z.abs() < 4.0, "sggx in a heterogeneous medium: z = {z}");
}

/// The mean and standard error of what a 1 × 16 meter at `origin` looking
/// along `direction` reads through a cube [−1, 1]³ of purely absorbing
/// `medium` (σ_t = 1 over the cube) with phase function `phase`, under a
/// sky of 1: the transmittance along its ray.
fn transmittance_through_cube(
    medium: &str,
    phase: &str,
    origin: &str,
    direction: &str,
) -> (f64, f64) {
    let sigma_t = match medium {
        "homogeneous" => r#"<float name="sigma_t" value="1"/>"#,
        _ => COVERING_UNIT_EXTINCTION,
    };
    let xml = format!(
        r#"<scene version="3.0.0">
<integrator type="volpath"><integer name="max_depth" value="4"/></integrator>
<sensor type="radiancemeter">
  <point name="origin" value="{origin}"/><vector name="direction" value="{direction}"/>
  <film type="hdrfilm"><integer name="width" value="1"/><integer name="height" value="16"/>
    <rfilter type="box"/></film>
</sensor>
<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
<shape type="cube"><bsdf type="null"/>
  <medium type="{medium}" name="interior">{sigma_t}<float name="albedo" value="0"/>{phase}</medium>
</shape>
</scene>"#
    );
    let loaded = load_scene_str(&xml, Path::new("cube.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    let out = render(
        &loaded.scene,
        loaded.integrator.as_ref(),
        &RenderSettings { spp: 4096, seed: 3 },
        &|_| {},
    );
    common::pixel_mean_and_error(&out.image.data, 0)
}

/// Fibres along z, S = diag(1, 1, 4): σ(z) = 2, so 2 units of σ_t = 1
/// along z transmit e^−4 in both media. (Mitsuba 3.9.1's heterogeneous
/// medium keeps its majorant at σ_t and transmits about e^−2 = 0.133;
/// see the plugin's header.)
#[test]
fn sggx_projected_area_above_one_is_bounded_by_the_majorant() {
    let fibres = sggx_phase("fibres", &[[1.0, 1.0, 4.0, 0.0, 0.0, 0.0]; 2]);
    for medium in ["homogeneous", "heterogeneous"] {
        let want = (-4.0f64).exp();
        let (mean, se) = transmittance_through_cube(medium, &fibres, "0, 0, -5", "0, 0, 1");
        assert!(
            (mean - want).abs() < 4.0 * se + 1e-6,
            "{medium}: {mean} ± {se}, want {want}"
        );
    }
}

#[test]
fn bad_sggx_matrices_are_refused_at_their_line() {
    let error = |phase: &str| match load_scene_str(&scene(phase, (1, 1)), Path::new("bad.xml"), &[])
    {
        Ok(_) => panic!("{phase} loaded"),
        Err(e) => e.to_string(),
    };
    let missing = error(r#"<phase type="sggx"/>"#);
    assert!(
        missing.contains("bad.xml:18") && missing.contains("\"S\""),
        "{missing}"
    );
    let dir = common::scratch_dir("sggx-bad");
    let three = dir.join("three.vol");
    common::write_vol(&three, [1, 1, 1], 3, &[1.0, 1.0, 1.0]);
    let e = error(&format!(
        r#"<phase type="sggx"><volume type="gridvolume" name="S"><string name="filename" value="{}"/></volume></phase>"#,
        three.display()
    ));
    assert!(
        e.contains("bad.xml:18") && e.contains("needs 6 channels"),
        "{e}"
    );
    let constant = error(r#"<phase type="sggx"><volume type="constvolume" name="S"/></phase>"#);
    assert!(
        constant.contains("six-channel gridvolume, not a constvolume"),
        "{constant}"
    );
    // A six-channel grid where a density is expected.
    let six = dir.join("six.vol");
    common::write_vol(&six, [1, 1, 1], 6, &[1.0; 6]);
    let density = scene(r#"<phase type="isotropic"/>"#, (1, 1)).replace(
        r#"<medium type="homogeneous" name="interior">
    <float name="sigma_t" value="1"/>"#,
        &format!(
            r#"<medium type="heterogeneous" name="interior">
    <volume type="gridvolume" name="sigma_t"><string name="filename" value="{}"/></volume>"#,
            six.display()
        ),
    );
    let e = match load_scene_str(&density, Path::new("bad.xml"), &[]) {
        Ok(_) => panic!("a six-channel density loaded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("only an sggx phase function's S"), "{e}");
    let blended = error(&format!(
        r#"<phase type="blendphase"><phase type="isotropic"/>{}</phase>"#,
        sggx_phase("blend", &[[1.0, 1.0, 1.0, 0.0, 0.0, 0.0]])
    ));
    assert!(blended.contains("cannot blend an sggx"), "{blended}");
}

/// S varying over space is read at every point of a flight, in both media
/// (a homogeneous medium is tracked as a heterogeneous one then): flakes
/// at x < −0.5 blend into fibres along z at x > 0.5, and a ray crossing
/// the cube obliquely is attenuated by ∫ σ_t σ(d; S(p)) dt, integrated
/// here (Mitsuba 3.9.1 reads 0.229 ± 0.005 in its homogeneous medium).
#[test]
fn sggx_varying_over_space_is_read_along_the_flight() {
    let (s0, s1) = (
        [1.0, 1.0, 0.1, 0.0, 0.0, 0.0],
        [0.1, 0.1, 1.0, 0.0, 0.0, 0.0],
    );
    let phase = sggx_phase("varying", &[s0, s1]).replace(
        "</volume>",
        r#"<transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform></volume>"#,
    );
    let (o, d) = (
        glam::DVec3::new(-0.5, 0.3, -5.0),
        glam::DVec3::new(0.1, 0.0, 1.0).normalize(),
    );
    // Optical depth through z ∈ [−1, 1].
    let (t0, t1) = ((-1.0 - o.z) / d.z, (1.0 - o.z) / d.z);
    let n = 20_000;
    let depth: f64 = (0..n)
        .map(|i| {
            let p = o + d * (t0 + (t1 - t0) * (i as f64 + 0.5) / n as f64);
            let w = (((p.x + 1.0) / 2.0 - 0.25) / 0.5).clamp(0.0, 1.0);
            let s: Vec<f64> = (0..6)
                .map(|k| (1.0 - w) * s0[k] as f64 + w * s1[k] as f64)
                .collect();
            (d.x * d.x * s[0] + d.y * d.y * s[1] + d.z * d.z * s[2]).sqrt()
        })
        .sum::<f64>()
        * (t1 - t0)
        / n as f64;
    let want = (-depth).exp();
    for medium in ["homogeneous", "heterogeneous"] {
        let (mean, se) = transmittance_through_cube(medium, &phase, "-0.5, 0.3, -5", "0.1, 0, 1");
        assert!(
            (mean - want).abs() < 4.0 * se,
            "{medium}: {mean} ± {se}, want {want}"
        );
    }
}
