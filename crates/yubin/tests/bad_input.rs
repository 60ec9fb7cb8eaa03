//! Bad input to the `yubin` binary: every case must fail cleanly.
//!
//! Each test writes its input into a fresh directory, runs the real binary
//! there and checks that it
//!
//! - exits with code 1 (clap's usage errors: 2),
//! - names the file and, where there is one, the line (`scene.xml:7:`),
//! - says what is wrong (the misspelt parameter, the unknown type, ...),
//! - does not panic, and
//! - leaves nothing behind: no output image and no temporary next to it.
//!
//! A positive control renders a valid scene, so that a binary which fails
//! on everything cannot pass.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const YUBIN: &str = env!("CARGO_BIN_EXE_yubin");

/// The output every render writes to, relative to the test's directory.
const OUT: &str = "out.exr";

/// A fresh, empty directory under the target's temporary folder, removed
/// when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let path = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join("bad_input")
            .join(format!("{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).expect("cannot create the test directory");
        Self(path)
    }

    fn path(&self) -> &Path {
        &self.0
    }

    fn write(&self, name: &str, contents: impl AsRef<[u8]>) {
        std::fs::write(self.0.join(name), contents).expect("cannot write a test input");
    }

    /// The names of the files in the directory, hidden ones included.
    fn listing(&self) -> BTreeSet<String> {
        std::fs::read_dir(&self.0)
            .expect("cannot list the test directory")
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Runs `yubin ARGS` in `dir`.
fn yubin(dir: &TempDir, args: &[&str]) -> Output {
    Command::new(YUBIN)
        .args(args)
        .current_dir(dir.path())
        .env_remove("RUST_BACKTRACE")
        .env_remove("OCIO")
        .output()
        .expect("cannot run the yubin binary")
}

/// Runs `yubin ARGS` in `dir`, expects it to fail with `code` and to leave
/// the directory as it was, and returns its stderr.
fn expect_failure(dir: &TempDir, args: &[&str], code: i32) -> String {
    let before = dir.listing();
    let out = yubin(dir, args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let context = format!("yubin {}\nstderr:\n{stderr}", args.join(" "));
    assert_eq!(out.status.code(), Some(code), "exit status of {context}");
    assert!(!stderr.contains("panicked"), "panic in {context}");
    assert!(
        stderr.trim_start().starts_with("error"),
        "no error message in {context}"
    );
    assert_eq!(dir.listing(), before, "files left behind by {context}");
    assert!(
        !dir.path().join(OUT).exists(),
        "output written by {context}"
    );
    stderr
}

/// Asserts that `stderr` contains every one of `needles`.
fn assert_mentions(stderr: &str, needles: &[&str]) {
    for needle in needles {
        assert!(
            stderr.contains(needle),
            "stderr does not mention {needle:?}:\n{stderr}"
        );
    }
}

/// The 1-based number of the first line of `text` that contains `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("{needle:?} is not in the scene"))
        + 1
}

/// A scene of an 8x8 film at 1 spp, a constant sky, and `body`.
fn scene(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
	<sensor type="perspective">
		<float name="fov" value="40"/>
		<transform name="to_world">
			<lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/>
		</transform>
		<sampler type="independent">
			<integer name="sample_count" value="1"/>
		</sampler>
		<film type="hdrfilm">
			<integer name="width" value="8"/>
			<integer name="height" value="8"/>
		</film>
	</sensor>
	<emitter type="constant"/>
{body}
</scene>
"#
    )
}

/// A diffuse sphere, the body of the valid scene.
const SPHERE: &str = r#"	<shape type="sphere">
		<bsdf type="diffuse">
			<rgb name="reflectance" value="0.5, 0.5, 0.5"/>
		</bsdf>
	</shape>"#;

/// Renders `xml`, written as scene.xml in `dir`, expecting failure with
/// exit code 1; returns stderr.
fn render_fails(dir: &TempDir, xml: &str) -> String {
    dir.write("scene.xml", xml);
    expect_failure(dir, &["render", "scene.xml", "-o", OUT, "--quiet"], 1)
}

/// Renders `xml` in `dir`, expecting failure with a message that names
/// `scene.xml` at the line holding `line_needle` and mentions `needles`.
fn fails_at_line(dir: &TempDir, xml: &str, line_needle: &str, needles: &[&str]) {
    let stderr = render_fails(dir, xml);
    let line = format!("scene.xml:{}", line_of(xml, line_needle));
    let mut all = vec![line.as_str()];
    all.extend_from_slice(needles);
    assert_mentions(&stderr, &all);
}

/// Renders `scene.xml` in `dir` and expects an EXR at [`OUT`] and nothing
/// else new.
fn render_succeeds(dir: &TempDir) {
    let before = dir.listing();
    let out = yubin(dir, &["render", "scene.xml", "-o", OUT, "--quiet"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "render failed: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let exr = std::fs::read(dir.path().join(OUT)).expect("no output image");
    assert!(
        exr.starts_with(&[0x76, 0x2f, 0x31, 0x01]),
        "the output is not an OpenEXR file"
    );
    let mut expected = before;
    expected.insert(OUT.to_string());
    assert_eq!(dir.listing(), expected, "unexpected files after a render");
}

#[test]
fn valid_scene_renders() {
    let dir = TempDir::new("valid_scene_renders");
    dir.write("scene.xml", scene(SPHERE));
    render_succeeds(&dir);
}

#[test]
fn malformed_xml_names_the_line() {
    let dir = TempDir::new("malformed_xml_names_the_line");
    // The diffuse BSDF is never closed: the parser finds out at the
    // </shape> that follows it.
    let body = "\t<shape type=\"sphere\">\n\t\t<bsdf type=\"diffuse\">\n\t</shape>";
    let xml = scene(body);
    let stderr = render_fails(&dir, &xml);
    let open = line_of(&xml, "<bsdf type=\"diffuse\">");
    let close = line_of(&xml, "</shape>");
    assert!(
        stderr.contains(&format!("scene.xml:{open}:"))
            || stderr.contains(&format!("scene.xml:{close}:")),
        "neither line {open} nor line {close} is named:\n{stderr}"
    );
    assert_mentions(&stderr, &["bsdf"]);
}

#[test]
fn unknown_plugin_type_names_the_line_and_type() {
    let dir = TempDir::new("unknown_plugin_type");
    let xml = scene(&SPHERE.replace("\"diffuse\"", "\"difuse\""));
    let stderr = render_fails(&dir, &xml);
    let line = line_of(&xml, "difuse");
    assert_mentions(&stderr, &[&format!("scene.xml:{line}:"), "\"difuse\""]);
}

#[test]
fn misspelt_parameter_names_the_line_and_parameter() {
    let dir = TempDir::new("misspelt_parameter");
    let xml = scene(&SPHERE.replace("reflectance", "reflectanse"));
    let stderr = render_fails(&dir, &xml);
    let line = line_of(&xml, "reflectanse");
    assert_mentions(
        &stderr,
        &[
            &format!("scene.xml:{line}:"),
            "unknown parameter \"reflectanse\" for bsdf \"diffuse\"",
        ],
    );
}

#[test]
fn wrong_parameter_type_names_the_line_and_parameter() {
    let dir = TempDir::new("wrong_parameter_type");
    let xml = scene(SPHERE).replace(
        "<float name=\"fov\" value=\"40\"/>",
        "<string name=\"fov\" value=\"abc\"/>",
    );
    let stderr = render_fails(&dir, &xml);
    let line = line_of(&xml, "name=\"fov\"");
    assert_mentions(&stderr, &[&format!("scene.xml:{line}:"), "fov", "float"]);
}

#[test]
fn missing_mesh_file_names_it_and_the_searched_paths() {
    let dir = TempDir::new("missing_mesh_file");
    let body =
        "\t<shape type=\"obj\">\n\t\t<string name=\"filename\" value=\"nope.obj\"/>\n\t</shape>";
    let xml = scene(body);
    let stderr = render_fails(&dir, &xml);
    let shape = line_of(&xml, "type=\"obj\"");
    let filename = line_of(&xml, "nope.obj");
    assert!(
        stderr.contains(&format!("scene.xml:{shape}:"))
            || stderr.contains(&format!("scene.xml:{filename}:")),
        "the line of the reference is not named:\n{stderr}"
    );
    assert_mentions(&stderr, &["\"nope.obj\"", "searched"]);
    // The searched paths: at least the one next to the scene.
    let searched = stderr.split("searched").nth(1).expect("no searched paths");
    assert!(
        searched.contains("nope.obj"),
        "no searched path in:\n{stderr}"
    );
}

#[test]
fn missing_scene_file_is_named() {
    let dir = TempDir::new("missing_scene_file");
    let stderr = expect_failure(
        &dir,
        &["render", "does-not-exist.xml", "-o", OUT, "--quiet"],
        1,
    );
    assert_mentions(&stderr, &["does-not-exist.xml"]);
    // Without -o, the default output name must not appear either.
    let stderr = expect_failure(&dir, &["render", "does-not-exist.xml", "--quiet"], 1);
    assert_mentions(&stderr, &["does-not-exist.xml"]);
}

/// A little-endian binary PLY of `n` triangles in the z = 0 plane, and
/// the length of its header.
fn binary_ply(n: u32) -> (Vec<u8>, usize) {
    let header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n\
         element face {n}\nproperty list uchar int vertex_indices\nend_header\n",
        3 * n
    );
    let mut out = header.into_bytes();
    let header_len = out.len();
    for i in 0..n {
        let x = i as f32 * 0.3 - 0.5;
        for [px, py] in [[x, -0.5], [x + 0.25, -0.5], [x, 0.5]] {
            for v in [px, py, 0.0f32] {
                out.extend(v.to_le_bytes());
            }
        }
    }
    for i in 0..n as i32 {
        out.push(3);
        for k in 0..3 {
            out.extend((3 * i + k).to_le_bytes());
        }
    }
    (out, header_len)
}

#[test]
fn truncated_binary_ply_is_named() {
    let dir = TempDir::new("truncated_binary_ply");
    let body =
        "\t<shape type=\"ply\">\n\t\t<string name=\"filename\" value=\"mesh.ply\"/>\n\t</shape>";
    dir.write("scene.xml", scene(body));
    let n = 4;
    let (ply, header_len) = binary_ply(n);
    // The whole file loads: the failure below is the truncation alone.
    dir.write("mesh.ply", &ply);
    render_succeeds(&dir);
    std::fs::remove_file(dir.path().join(OUT)).unwrap();
    // Cut in the middle of the third face.
    let faces_start = header_len + 3 * n as usize * 12;
    let cut = faces_start + 2 * 13 + 6;
    assert!(cut < ply.len());
    dir.write("mesh.ply", &ply[..cut]);
    let stderr = expect_failure(&dir, &["render", "scene.xml", "-o", OUT, "--quiet"], 1);
    assert_mentions(&stderr, &["mesh.ply", "truncated"]);
}

#[test]
fn obj_face_index_out_of_range_names_the_file_and_line() {
    let dir = TempDir::new("obj_face_index_out_of_range");
    let obj = "# a triangle and a bad face\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n";
    dir.write("bad.obj", obj);
    let body =
        "\t<shape type=\"obj\">\n\t\t<string name=\"filename\" value=\"bad.obj\"/>\n\t</shape>";
    let stderr = render_fails(&dir, &scene(body));
    let line = line_of(obj, "f 1 2 7");
    assert_mentions(&stderr, &[&format!("bad.obj:{line}:"), "7"]);
}

#[test]
fn undefined_variable_names_the_line() {
    let dir = TempDir::new("undefined_variable");
    let xml = scene(&SPHERE.replace("0.5, 0.5, 0.5", "$albedo"));
    let stderr = render_fails(&dir, &xml);
    let line = line_of(&xml, "$albedo");
    assert_mentions(&stderr, &[&format!("scene.xml:{line}:"), "albedo"]);
}

#[test]
fn malformed_define_is_a_usage_error() {
    let dir = TempDir::new("malformed_define");
    dir.write("scene.xml", scene(SPHERE));
    // clap reports a bad argument with its usage-error code, 2.
    let stderr = expect_failure(
        &dir,
        &["render", "scene.xml", "-o", OUT, "--quiet", "-D", "novalue"],
        2,
    );
    assert_mentions(&stderr, &["novalue"]);
}

#[test]
fn unsupported_output_extension_is_named() {
    let dir = TempDir::new("unsupported_output_extension");
    dir.write("scene.xml", scene(SPHERE));
    let stderr = expect_failure(
        &dir,
        &["render", "scene.xml", "-o", "out.tiff", "--quiet"],
        1,
    );
    assert_mentions(&stderr, &["out.tiff"]);
    let lower = stderr.to_lowercase();
    assert!(
        lower.contains("unsupported") || lower.contains("format") || lower.contains("extension"),
        "the problem is not named:\n{stderr}"
    );
}

#[test]
fn compare_with_a_missing_file_names_it() {
    let dir = TempDir::new("compare_missing_file");
    dir.write("scene.xml", scene(SPHERE));
    render_succeeds(&dir);
    std::fs::rename(dir.path().join(OUT), dir.path().join("ref.exr")).unwrap();
    let stderr = expect_failure(&dir, &["compare", "missing.exr", "ref.exr"], 1);
    assert_mentions(&stderr, &["missing.exr"]);
    let stderr = expect_failure(&dir, &["compare", "ref.exr", "missing.exr"], 1);
    assert_mentions(&stderr, &["missing.exr"]);
}

/// Material errors: each case is a sphere's BSDF, the text its error must
/// contain, and a needle on the line it must name.
#[test]
fn material_errors_name_the_line_and_the_problem() {
    let cases: &[(&str, &[&str], &str)] = &[
        (
            r#"<bsdf type="conductor"><string name="material" value="Unobtainium"/></bsdf>"#,
            &["unknown conductor \"Unobtainium\"", "Au", "Cu"],
            "Unobtainium",
        ),
        (
            r#"<bsdf type="dielectric"><string name="int_ior" value="glasss"/></bsdf>"#,
            &["\"glasss\"", "bk7", "water"],
            "glasss",
        ),
        (
            r#"<bsdf type="dielectric"><float name="int_ior" value="-1.5"/></bsdf>"#,
            &["int_ior", "positive"],
            "-1.5",
        ),
        (
            r#"<bsdf type="roughconductor"><float name="alpha" value="0"/></bsdf>"#,
            &["alpha"],
            "name=\"alpha\"",
        ),
        (
            r#"<bsdf type="roughconductor"><texture type="checkerboard" name="distribution"/></bsdf>"#,
            &["distribution", "string"],
            "name=\"distribution\"",
        ),
        (
            r#"<bsdf type="diffuse"><string name="reflectance" value="red"/></bsdf>"#,
            &["reflectance"],
            "value=\"red\"",
        ),
        (
            r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/></bsdf>"#,
            &["two nested BSDFs", "found 1"],
            "blendbsdf",
        ),
        (
            r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="nowhere.png"/></texture></bsdf>"#,
            &["nowhere.png", "searched"],
            "nowhere.png",
        ),
        (
            r#"<bsdf type="principled"><float name="metallic" value="1.5"/></bsdf>"#,
            &["metallic", "[0, 1]", "1.5"],
            "name=\"metallic\"",
        ),
        (
            r#"<bsdf type="principled"><float name="eta" value="1.4"/><float name="specular" value="0.3"/></bsdf>"#,
            &["\"eta\" or \"specular\", not both"],
            "name=\"specular\"",
        ),
        (
            r#"<bsdf type="principledthin"><float name="diff_trans" value="2.5"/></bsdf>"#,
            &["diff_trans", "[0, 2]"],
            "name=\"diff_trans\"",
        ),
        (
            r#"<bsdf type="principledthin"><float name="eta" value="0"/></bsdf>"#,
            &["eta", "positive"],
            "name=\"eta\"",
        ),
    ];
    for (i, (bsdf, needles, line_needle)) in cases.iter().enumerate() {
        let dir = TempDir::new(&format!("material_error_{i}"));
        let xml = scene(&format!(
            "\t<shape type=\"sphere\">\n\t\t{bsdf}\n\t</shape>"
        ));
        fails_at_line(&dir, &xml, line_needle, needles);
    }
}

#[test]
fn corrupt_texture_image_is_named() {
    let dir = TempDir::new("corrupt_texture_image");
    dir.write("broken.png", b"\x89PNG\r\n\x1a\nnot really a png");
    let xml = scene(
        "\t<shape type=\"sphere\">\n\t\t<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"broken.png\"/></texture></bsdf>\n\t</shape>",
    );
    let stderr = render_fails(&dir, &xml);
    assert_mentions(&stderr, &["broken.png"]);
}

/// A normal map on a mesh without texture coordinates is not an error:
/// as in Mitsuba 3, such a mesh's uv are the hit's barycentric
/// coordinates and its tangent the triangle's first edge.
#[test]
fn normalmap_on_a_mesh_without_uvs_renders() {
    let dir = TempDir::new("normalmap_without_uvs");
    dir.write(
        "quad.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n",
    );
    let body = "\t<shape type=\"obj\">\n\t\t<string name=\"filename\" value=\"quad.obj\"/>\n\t\t<bsdf type=\"normalmap\">\n\t\t\t<rgb name=\"normalmap\" value=\"0.7, 0.5, 0.9\"/>\n\t\t\t<bsdf type=\"diffuse\"/>\n\t\t</bsdf>\n\t</shape>";
    dir.write("scene.xml", scene(body));
    render_succeeds(&dir);
}

/// The bytes of a `.vol` grid: version, resolution, one channel, values.
fn vol_bytes(version: u8, res: [i32; 3], values: &[f32]) -> Vec<u8> {
    let mut b = b"VOL".to_vec();
    b.push(version);
    b.extend(1i32.to_le_bytes());
    for r in res {
        b.extend(r.to_le_bytes());
    }
    b.extend(1i32.to_le_bytes());
    for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        b.extend(v.to_le_bytes());
    }
    for v in values {
        b.extend(v.to_le_bytes());
    }
    b
}

/// Media errors: a bad `.vol` file (truncated, another version, a negative
/// density) names the file and the line that reads it; a medium referred
/// to but never defined and a phase function's `g` outside (−1, 1) name
/// their line. Exit code 1 and no output image.
#[test]
fn media_errors_name_the_file_and_line() {
    let smoke = |file: &str| {
        format!(
            "\t<medium type=\"heterogeneous\" id=\"smoke\">\n\t\t<volume type=\"gridvolume\" name=\"sigma_t\">\n\t\t\t<string name=\"filename\" value=\"{file}\"/>\n\t\t</volume>\n\t</medium>\n\t<shape type=\"sphere\">\n\t\t<bsdf type=\"null\"/>\n\t\t<ref id=\"smoke\" name=\"interior\"/>\n\t</shape>"
        )
    };
    let good = vol_bytes(3, [2, 2, 2], &[0.5; 8]);
    let files: &[(&str, Vec<u8>, &[&str])] = &[
        (
            "truncated.vol",
            good[..good.len() - 5].to_vec(),
            &["truncated.vol", "truncated"],
        ),
        (
            "v2.vol",
            vol_bytes(2, [2, 2, 2], &[0.5; 8]),
            &["v2.vol", "version 2"],
        ),
        (
            "negative.vol",
            vol_bytes(3, [2, 2, 2], &[0.5, 0.5, -1.0, 0.5, 0.5, 0.5, 0.5, 0.5]),
            &["negative.vol", "voxel [0, 1, 0]", "-1"],
        ),
    ];
    for (name, bytes, needles) in files {
        let dir = TempDir::new(&format!("media_error_{name}"));
        dir.write(name, bytes);
        let xml = scene(&smoke(name));
        fails_at_line(&dir, &xml, &format!("value=\"{name}\""), needles);
    }
    let cases: &[(&str, &[&str], &str)] = &[
        (
            "\t<shape type=\"sphere\">\n\t\t<bsdf type=\"null\"/>\n\t\t<ref id=\"fog\" name=\"interior\"/>\n\t</shape>",
            &["fog"],
            "id=\"fog\"",
        ),
        (
            "\t<medium type=\"homogeneous\" id=\"fog\">\n\t\t<phase type=\"hg\">\n\t\t\t<float name=\"g\" value=\"1.2\"/>\n\t\t</phase>\n\t</medium>\n\t<shape type=\"sphere\">\n\t\t<bsdf type=\"null\"/>\n\t\t<ref id=\"fog\" name=\"interior\"/>\n\t</shape>",
            &["\"g\"", "1.2"],
            "name=\"g\"",
        ),
        (
            "\t<medium type=\"homogeneous\" id=\"fog\">\n\t\t<float name=\"sigma_t\" value=\"-2\"/>\n\t</medium>\n\t<shape type=\"sphere\">\n\t\t<bsdf type=\"null\"/>\n\t\t<ref id=\"fog\" name=\"interior\"/>\n\t</shape>",
            &["sigma_t"],
            "name=\"sigma_t\"",
        ),
        (
            "\t<shape type=\"sphere\">\n\t\t<bsdf type=\"null\"/>\n\t\t<texture type=\"checkerboard\" name=\"interior\"/>\n\t</shape>",
            &["interior", "medium"],
            "name=\"interior\"",
        ),
    ];
    for (i, (body, needles, line_needle)) in cases.iter().enumerate() {
        let dir = TempDir::new(&format!("media_error_{i}"));
        let xml = scene(body);
        fails_at_line(&dir, &xml, line_needle, needles);
    }
}

/// An output directory that does not exist is an error before rendering
/// starts, naming it; nothing is written.
#[test]
fn unwritable_output_directory_fails_before_rendering() {
    let dir = TempDir::new("unwritable_output");
    dir.write("scene.xml", scene(SPHERE));
    let before = dir.listing();
    let stderr = expect_failure(
        &dir,
        &["render", "scene.xml", "-o", "missing/out.exr", "--quiet"],
        1,
    );
    assert_mentions(&stderr, &["missing", "writable directory"]);
    assert_eq!(dir.listing(), before);
}

/// A texture (spectrum, volume, phase function) declared with an id and
/// never referenced is built like the rest (as Mitsuba loads it): a valid
/// one renders, a misspelt parameter in it is named at its line.
#[test]
fn unreferenced_texture_is_checked_not_refused() {
    let texture = |param: &str| {
        format!(
            "\t<texture type=\"checkerboard\" id=\"t\">\n\t\t<rgb name=\"{param}\" value=\"0.2\"/>\n\t</texture>\n{SPHERE}"
        )
    };
    let dir = TempDir::new("unreferenced_texture");
    dir.write("scene.xml", scene(&texture("color0")));
    render_succeeds(&dir);
    let dir = TempDir::new("unreferenced_texture_typo");
    let xml = scene(&texture("colr0"));
    fails_at_line(&dir, &xml, "colr0", &["colr0"]);
    // The same for the other families a scene may declare ahead.
    let dir = TempDir::new("unreferenced_others");
    let others = format!(
        "\t<spectrum type=\"blackbody\" id=\"s\"><float name=\"temperature\" value=\"3000\"/></spectrum>\n\t<volume type=\"constvolume\" id=\"v\"><float name=\"value\" value=\"2\"/></volume>\n{SPHERE}"
    );
    dir.write("scene.xml", scene(&others));
    render_succeeds(&dir);
    let dir = TempDir::new("unreferenced_phase_typo");
    let xml = scene(&format!(
        "\t<phase type=\"hg\" id=\"p\">\n\t\t<float name=\"gg\" value=\"0.5\"/>\n\t</phase>\n{SPHERE}"
    ));
    fails_at_line(&dir, &xml, "\"gg\"", &["gg"]);
}

/// A small OCIO config: a linear space, an sRGB display space, a view
/// whose colour space uses a transform yubin does not implement, one
/// whose LUT is missing, and a look.
const OCIO_CONFIG: &str = r#"ocio_profile_version: 2
roles:
  scene_linear: Linear
displays:
  sRGB:
    - !<View> {name: Standard, colorspace: sRGB}
    - !<View> {name: Graded, colorspace: Graded}
    - !<View> {name: Lut, colorspace: Lut}
looks:
  - !<Look>
    name: Bright
    process_space: Linear
    transform: !<MatrixTransform> {matrix: [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1]}
colorspaces:
  - !<ColorSpace>
    name: Linear
  - !<ColorSpace>
    name: sRGB
    from_scene_reference: !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055, direction: inverse}
  - !<ColorSpace>
    name: Graded
    from_scene_reference: !<GroupTransform>
      children:
        - !<MatrixTransform> {matrix: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}
        - !<GradingToneTransform>
          shadows: {rgb: [0.2, 0.2, 0.2], master: 0.35, start: 0.4, pivot: 0.1}
  - !<ColorSpace>
    name: Lut
    from_scene_reference: !<FileTransform> {src: missing.cube, interpolation: tetrahedral}
"#;

#[test]
fn ocio_errors_name_the_problem_and_write_nothing() {
    let dir = TempDir::new("ocio_errors");
    dir.write("scene.xml", scene(SPHERE));
    dir.write("config.ocio", OCIO_CONFIG);
    // `yubin render scene.xml -o out.png --quiet` with `extra`, and the
    // same with the config.
    let plain = |extra: &[&str]| {
        let mut args = vec!["render", "scene.xml", "-o", "out.png", "--quiet"];
        args.extend_from_slice(extra);
        args.into_iter().map(str::to_string).collect::<Vec<_>>()
    };
    let render = |extra: &[&str]| {
        let mut args = vec!["--ocio", "config.ocio"];
        args.extend_from_slice(extra);
        plain(&args)
    };
    let fails = |args: Vec<String>| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        expect_failure(&dir, &args, 1)
    };
    // An unsupported transform: named, with the config and its line.
    let line = line_of(OCIO_CONFIG, "GradingToneTransform").to_string();
    let stderr = fails(render(&["--view", "Graded"]));
    assert_mentions(
        &stderr,
        &["GradingToneTransform", &format!("config.ocio:{line}")],
    );
    // A LUT file that is not there: named with the places searched.
    let stderr = fails(render(&["--view", "Lut"]));
    assert_mentions(&stderr, &["missing.cube", "config.ocio"]);
    // An unknown view and an unknown look: named, with the known ones.
    let stderr = fails(render(&["--view", "Filmic"]));
    assert_mentions(&stderr, &["Filmic", "Standard, Graded, Lut"]);
    let stderr = fails(render(&["--look", "Punchy"]));
    assert_mentions(&stderr, &["Punchy", "Bright"]);
    // A display that does not exist.
    let stderr = fails(render(&["--display", "P3"]));
    assert_mentions(&stderr, &["P3", "sRGB"]);
    // Not a config at all, and a missing one.
    dir.write("broken.ocio", "colorspaces: [\n");
    let stderr = fails(plain(&["--ocio", "broken.ocio"]));
    assert_mentions(&stderr, &["broken.ocio"]);
    let stderr = fails(plain(&["--ocio", "nowhere.ocio"]));
    assert_mentions(&stderr, &["nowhere.ocio"]);
    // A view without a config, and both a config and a tone curve.
    let stderr = fails(plain(&["--view", "Filmic"]));
    assert_mentions(&stderr, &["--ocio"]);
    let stderr = fails(render(&["--tonemap", "filmic"]));
    assert_mentions(&stderr, &["--tonemap", "--ocio"]);
    // A broken config that only $OCIO names: a warning, the srgb curve;
    // with a view asked for, the error.
    let out = Command::new(YUBIN)
        .args(plain(&[]))
        .current_dir(dir.path())
        .env("OCIO", "broken.ocio")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: $OCIO") && stderr.contains("broken.ocio"),
        "{stderr}"
    );
    assert!(dir.path().join("out.png").exists());
    std::fs::remove_file(dir.path().join("out.png")).unwrap();
    let out = Command::new(YUBIN)
        .args(plain(&["--view", "Filmic"]))
        .current_dir(dir.path())
        .env("OCIO", "broken.ocio")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(!dir.path().join("out.png").exists());
    // The same config renders through its valid view and look.
    let args = render(&["--view", "Standard", "--look", "Bright"]);
    let out = yubin(&dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("out.png").exists());
}
