//! Objects declared with an id at the top level and referenced by nobody
//! are built and checked, as Mitsuba loads every declared object: their
//! parameters are read (no misleading "unknown parameter"), and a bad
//! value in them is still an error at its line.

use std::path::Path;
use yubin_scene::build::load_scene_str;

fn load(declared: &str) -> Result<(), String> {
    let xml = format!(
        r#"<scene version="3.0.0">
{declared}
<shape type="sphere"/>
<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
</scene>"#
    );
    load_scene_str(&xml, Path::new("declared.xml"), &[])
        .map(|_| ())
        .map_err(|e| e.to_string())
}

#[test]
fn unreferenced_sampler_film_and_filter_load() {
    for declared in [
        r#"<sampler type="independent" id="s"><integer name="sample_count" value="16"/></sampler>"#,
        r#"<film type="hdrfilm" id="f"><integer name="width" value="32"/></film>"#,
        r#"<rfilter type="gaussian" id="r"><float name="stddev" value="0.4"/></rfilter>"#,
    ] {
        assert_eq!(load(declared), Ok(()), "{declared}");
    }
}

#[test]
fn unreferenced_objects_are_still_checked() {
    let e = load(
        r#"<sampler type="independent" id="s"><integer name="sample_count" value="-3"/></sampler>"#,
    )
    .expect_err("a negative sample count");
    assert!(
        e.contains("declared.xml:2") && e.contains("sample_count"),
        "{e}"
    );
    let e = load(r#"<film type="hdrfilm" id="f"><integer name="widht" value="32"/></film>"#)
        .expect_err("a misspelt parameter");
    assert!(e.contains("widht"), "{e}");
}
