//! No silent wrong images: a scene whose texture holds a NaN makes NaN
//! samples; they are dropped from the image (the EXR holds no NaN or
//! infinity), counted with the pixels they fell in, and the first is
//! named by pixel and sample index, which `--crop x,y,1,1 --spp i+1`
//! renders again. `--strict` lists them and exits with 1, the image
//! still written.

use std::path::{Path, PathBuf};
use std::process::Command;
use yubin_scene::image_io::{read_image, ColorHandling};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("yubin-nonfinite-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A sphere whose diffuse reflectance is a 1 × 1 PFM with a NaN red
/// channel, under a constant sky.
fn write_scene(dir: &Path) {
    let mut pfm = b"PF\n1 1\n-1.0\n".to_vec();
    for v in [f32::NAN, 0.5, 0.5] {
        pfm.extend(v.to_le_bytes());
    }
    std::fs::write(dir.join("nan.pfm"), pfm).unwrap();
    std::fs::write(
        dir.join("nan.xml"),
        r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
  <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
</sensor>
<emitter type="constant"/>
<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
  <string name="filename" value="nan.pfm"/></texture></bsdf></shape>
</scene>"#,
    )
    .unwrap();
}

fn yubin(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_yubin"))
        .current_dir(dir)
        .arg("render")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The first "pixel (x, y) sample i" a report names.
fn first_named(stderr: &str) -> (u32, u32, u32) {
    let rest = stderr
        .split("pixel (")
        .nth(1)
        .unwrap_or_else(|| panic!("no pixel named: {stderr}"));
    let (xy, rest) = rest.split_once(") sample ").unwrap();
    let (x, y) = xy.split_once(", ").unwrap();
    let index = rest.split(' ').next().unwrap();
    (
        x.parse().unwrap(),
        y.parse().unwrap(),
        index.parse().unwrap(),
    )
}

#[test]
fn nan_samples_are_counted_named_and_kept_out_of_the_image() {
    let d = dir("report");
    write_scene(&d);
    let (code, stderr) = yubin(&d, &["nan.xml", "--spp", "4", "-o", "out.exr"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stderr.contains("were NaN or infinite and were dropped") && stderr.contains(" pixels "),
        "{stderr}"
    );
    let image = read_image(&d.join("out.exr"), ColorHandling::Raw).unwrap();
    assert!(image.data.iter().all(|v| v.is_finite()), "a NaN in the EXR");
    // The named sample, rendered alone, is NaN again.
    let (x, y, index) = first_named(&stderr);
    let crop = format!("{x},{y},1,1");
    let spp = (index + 1).to_string();
    let (code, again) = yubin(
        &d,
        &["nan.xml", "--crop", &crop, "--spp", &spp, "-o", "one.exr"],
    );
    assert_eq!(code, Some(0), "{again}");
    assert!(
        again.contains(&format!("pixel ({x}, {y}) sample {index}")),
        "not reproduced: {again}"
    );
    // --strict: every one listed, exit 1, the image written all the same.
    let (code, strict) = yubin(
        &d,
        &["nan.xml", "--spp", "4", "--strict", "-o", "strict.exr"],
    );
    assert_eq!(code, Some(1), "{strict}");
    assert!(
        strict.contains("--strict") && strict.matches("  pixel (").count() > 1,
        "{strict}"
    );
    assert!(d.join("strict.exr").exists());
    // A scene without NaNs says nothing of them.
    std::fs::write(d.join("nan.pfm"), {
        let mut pfm = b"PF\n1 1\n-1.0\n".to_vec();
        for v in [0.5f32, 0.5, 0.5] {
            pfm.extend(v.to_le_bytes());
        }
        pfm
    })
    .unwrap();
    let (code, clean) = yubin(
        &d,
        &["nan.xml", "--spp", "4", "--strict", "-o", "clean.exr"],
    );
    assert_eq!(code, Some(0), "{clean}");
    assert!(!clean.contains("NaN"), "{clean}");
    std::fs::remove_dir_all(&d).ok();
}
