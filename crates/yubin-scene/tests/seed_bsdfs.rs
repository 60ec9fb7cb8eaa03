//! `roughdiffuse`, `phong`, `difftrans` and the `phong` microfacet
//! distribution from scene files: Mitsuba 0.6 scenes with camelCase names
//! load, and bad input is a load error that names the parameter and the
//! line.

use std::path::PathBuf;
use yubin_scene::load_scene_str;

fn scene(version: &str, bsdf: &str) -> String {
    format!(
        r#"<scene version="{version}">
    <sensor type="perspective">
        <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>
    </sensor>
    <shape type="sphere">
        {bsdf}
    </shape>
</scene>"#
    )
}

fn path() -> PathBuf {
    std::env::temp_dir().join("yubin-seed-bsdfs-scene.xml")
}

fn load(version: &str, bsdf: &str) -> Result<(), String> {
    load_scene_str(&scene(version, bsdf), &path(), &[])
        .map(|_| ())
        .map_err(|e| format!("{e:#}"))
}

#[test]
fn mitsuba_06_scenes_load() {
    let bsdfs = [
        r#"<bsdf type="roughdiffuse"><rgb name="diffuseReflectance" value="0.5"/><float name="alpha" value="0.4"/><boolean name="useFastApprox" value="true"/></bsdf>"#,
        r#"<bsdf type="phong"><float name="exponent" value="40"/><spectrum name="specularReflectance" value="0.3"/><spectrum name="diffuseReflectance" value="0.4"/></bsdf>"#,
        r#"<bsdf type="difftrans"><spectrum name="transmittance" value="0.7"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><string name="distribution" value="phong"/><float name="alpha" value="0.2"/></bsdf>"#,
        r#"<bsdf type="roughdielectric"><string name="distribution" value="phong"/><float name="alpha" value="0.2"/></bsdf>"#,
        r#"<bsdf type="roughplastic"><string name="distribution" value="phong"/><float name="alpha" value="0.3"/></bsdf>"#,
    ];
    for b in bsdfs {
        load("0.6.0", b).unwrap_or_else(|e| panic!("{b}: {e}"));
    }
    load(
        "3.0.0",
        r#"<bsdf type="roughdiffuse"><rgb name="reflectance" value="0.5"/><boolean name="use_fast_approx" value="false"/></bsdf>"#,
    )
    .unwrap();
}

#[test]
fn bad_parameters_are_load_errors() {
    let cases = [
        (
            r#"<bsdf type="phong"><float name="exponent" value="-2"/></bsdf>"#,
            &["exponent", "-2"][..],
        ),
        (
            r#"<bsdf type="roughdiffuse"><float name="alpha" value="-0.5"/></bsdf>"#,
            &["alpha"][..],
        ),
        (
            r#"<bsdf type="roughconductor"><string name="distribution" value="blinn"/></bsdf>"#,
            &["distribution", "blinn", "phong"][..],
        ),
        (
            r#"<bsdf type="roughconductor"><string name="distribution" value="phong"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/></bsdf>"#,
            &["isotropic", "alpha_u"][..],
        ),
    ];
    for (bsdf, words) in cases {
        let err = load("3.0.0", bsdf).expect_err(bsdf);
        assert!(err.contains("scene.xml:6"), "{bsdf}: {err}");
        for w in words {
            assert!(err.contains(w), "{bsdf}: {err} (missing {w})");
        }
    }
}
