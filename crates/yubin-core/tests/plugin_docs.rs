//! Generates `docs/plugins.md`, the plugin reference, from the `//!` header
//! of every plugin file, and fails when the checked-in file is stale — the
//! way Mitsuba builds its manual from its plugin docstrings.
//!
//! A plugin file is a file in `src/<family>/` whose header begins with its
//! backticked scene type string and a colon (`` //! `diffuse`: ... ``).
//! Files that document several plugins at once (a header with an XML
//! snippet that does not begin that way, e.g. `shape/mesh.rs`) are listed
//! after the family's plugin files, headed by their path.
//!
//! Regenerate with `YUBIN_UPDATE_DOCS=1 cargo test -p yubin-core --test plugin_docs`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Families in manual order: source folder and the XML tag that holds them.
const FAMILIES: &[(&str, &str)] = &[
    ("shape", "shape"),
    ("bsdf", "bsdf"),
    ("texture", "texture"),
    ("light", "emitter"),
    ("medium", "medium"),
    ("phase", "phase"),
    ("volume", "volume"),
    ("camera", "sensor"),
    ("film", "film"),
    ("filter", "rfilter"),
    ("sampler", "sampler"),
    ("integrator", "integrator"),
];

/// Plugins the scene front end (`yubin-scene`) implements, as (family
/// directory, path relative to `crates/`): listed with their family.
const FRONT_END_PLUGINS: &[(&str, &str)] = &[("shape", "yubin-scene/src/gltf.rs")];

/// The spectrum plugins: Mitsuba 3.9.1's, all of which yubin's builder
/// reads (as RGB).
const SPECTRA: &[&str] = &[
    "blackbody",
    "d65",
    "irregular",
    "rawconstant",
    "regular",
    "srgb",
    "uniform",
];

/// Every plugin Mitsuba 3.9.1 ships (the `mitsuba/plugins` folder of its
/// wheel), by the XML tag that holds it.
const MITSUBA_PLUGINS: &[(&str, &[&str])] = &[
    (
        "shape",
        &[
            "bsplinecurve",
            "cube",
            "cylinder",
            "disk",
            "ellipsoids",
            "ellipsoidsmesh",
            "instance",
            "linearcurve",
            "merge",
            "obj",
            "ply",
            "rectangle",
            "sdfgrid",
            "serialized",
            "shapegroup",
            "sphere",
        ],
    ),
    (
        "bsdf",
        &[
            "blendbsdf",
            "bumpmap",
            "circular",
            "conductor",
            "dielectric",
            "diffuse",
            "hair",
            "mask",
            "measured",
            "measured_polarized",
            "normalmap",
            "null",
            "plastic",
            "polarizer",
            "pplastic",
            "principled",
            "principledthin",
            "retarder",
            "roughconductor",
            "roughdielectric",
            "roughplastic",
            "thindielectric",
            "twosided",
        ],
    ),
    (
        "texture",
        &["bitmap", "checkerboard", "mesh_attribute", "volume"],
    ),
    ("spectrum", SPECTRA),
    (
        "emitter",
        &[
            "area",
            "constant",
            "directional",
            "directionalarea",
            "envmap",
            "point",
            "projector",
            "spot",
            "sunsky",
            "timed_sunsky",
        ],
    ),
    ("medium", &["heterogeneous", "homogeneous"]),
    (
        "phase",
        &[
            "blendphase",
            "hg",
            "isotropic",
            "rayleigh",
            "sggx",
            "tabphase",
        ],
    ),
    ("volume", &["constvolume", "gridvolume"]),
    (
        "sensor",
        &[
            "batch",
            "distant",
            "irradiancemeter",
            "orthographic",
            "perspective",
            "radiancemeter",
            "thinlens",
        ],
    ),
    ("film", &["hdrfilm", "specfilm"]),
    (
        "rfilter",
        &[
            "box",
            "catmullrom",
            "gaussian",
            "lanczos",
            "mitchell",
            "tent",
        ],
    ),
    (
        "sampler",
        &[
            "independent",
            "ldsampler",
            "multijitter",
            "orthogonal",
            "stratified",
        ],
    ),
    (
        "integrator",
        &[
            "aov",
            "depth",
            "direct",
            "moment",
            "path",
            "ptracer",
            "stokes",
            "volpath",
            "volpathmis",
        ],
    ),
];

/// Mitsuba plugins of its polarized variants (RGB rendering has none).
const POLARIZED: &[&str] = &[
    "circular",
    "measured_polarized",
    "polarizer",
    "pplastic",
    "retarder",
    "stokes",
];

/// Mitsuba plugins of its spectral variants only.
const SPECTRAL: &[&str] = &["specfilm"];

/// Plugins the scene builder (`yubin-scene`) makes itself, beside the
/// core's plugin tables, by tag.
const BUILDER_PLUGINS: &[(&str, &[&str])] = &[
    ("shape", &["gltf", "instance", "merge", "shapegroup"]),
    ("emitter", &["area", "directionalarea"]),
    ("spectrum", SPECTRA),
];

/// The type strings yubin reads for `tag`: its family's plugin table and
/// what the builder adds.
fn yubin_plugins(tag: &str) -> Vec<&'static str> {
    fn names<T>(table: &[(&'static str, T)]) -> Vec<&'static str> {
        table.iter().map(|(n, _)| *n).collect()
    }
    let mut out = match tag {
        "shape" => names(yubin_core::shape::PLUGINS),
        "bsdf" => names(yubin_core::bsdf::PLUGINS),
        "texture" => names(yubin_core::texture::PLUGINS),
        "emitter" => names(yubin_core::light::PLUGINS),
        "medium" => names(yubin_core::medium::PLUGINS),
        "phase" => names(yubin_core::phase::PLUGINS),
        "volume" => names(yubin_core::volume::PLUGINS),
        "sensor" => names(yubin_core::camera::PLUGINS),
        "film" => names(yubin_core::film::PLUGINS),
        "rfilter" => names(yubin_core::filter::PLUGINS),
        "sampler" => names(yubin_core::sampler::PLUGINS),
        "integrator" => names(yubin_core::integrator::PLUGINS),
        _ => Vec::new(),
    };
    for (t, more) in BUILDER_PLUGINS {
        if *t == tag {
            out.extend(more.iter());
        }
    }
    out.sort();
    out.dedup();
    out
}

/// The coverage section: every plugin of Mitsuba 3.9.1 by family, whether
/// yubin reads it, and what yubin adds.
fn coverage() -> String {
    let mut md = String::from("<a id=\"coverage\"></a>\n\n## Coverage of Mitsuba 3.9.1\n\n");
    md.push_str(
        "Every plugin Mitsuba 3.9.1 ships, by the tag that names it, and whether a \
         yubin scene file can use it. The polarized variants' plugins and the \
         spectral `specfilm` are refused with a message saying yubin renders in \
         RGB (as Mitsuba's `*_rgb` variants, which lack them too). `blender` \
         (Mitsuba's Python-side loader of Blender scenes) is not a scene-file \
         plugin and is left out. yubin's own plugins are listed after each family.\n\n",
    );
    let (mut have, mut rgb) = (0, 0);
    md.push_str("| tag | in yubin | missing | not in RGB rendering | yubin's own |\n|---|---|---|---|---|\n");
    for (tag, names) in MITSUBA_PLUGINS {
        let ours = yubin_plugins(tag);
        let list = |v: Vec<&str>| {
            if v.is_empty() {
                "—".to_string()
            } else {
                v.iter()
                    .map(|n| format!("`{n}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        };
        let not_rgb = |n: &&&str| POLARIZED.contains(n) || SPECTRAL.contains(n);
        let present: Vec<&str> = names.iter().copied().filter(|n| ours.contains(n)).collect();
        let missing: Vec<&str> = names
            .iter()
            .filter(|n| !ours.contains(n) && !not_rgb(n))
            .copied()
            .collect();
        let refused: Vec<&str> = names.iter().filter(not_rgb).copied().collect();
        let own: Vec<&str> = ours
            .iter()
            .copied()
            .filter(|n| !names.contains(n) && *n != "film")
            .collect();
        have += present.len();
        rgb += names.len() - refused.len();
        let _ = writeln!(
            md,
            "| `{tag}` | {} | {} | {} | {} |",
            list(present),
            list(missing),
            list(refused),
            list(own)
        );
    }
    let _ = writeln!(
        md,
        "\nyubin reads {have} of the {rgb} plugins Mitsuba 3.9.1 has for RGB rendering."
    );
    md
}

struct Entry {
    /// The type string, or `None` for a file documenting several plugins.
    name: Option<String>,
    /// Where its source is, from the repository's root.
    source: String,
    /// Path relative to `src/`.
    file: String,
    /// The header with `//!` stripped.
    text: String,
}

/// The leading `//!` block of a source file, prefixes stripped.
fn header(src: &str) -> String {
    let mut out = String::new();
    for line in src.lines() {
        let Some(rest) = line.strip_prefix("//!") else {
            break;
        };
        out.push_str(rest.strip_prefix(' ').unwrap_or(rest));
        out.push('\n');
    }
    out
}

/// The type string a header begins with (`` `name`: ``).
fn type_name(header: &str) -> Option<String> {
    let rest = header.strip_prefix('`')?;
    let (name, after) = rest.split_once('`')?;
    let ok = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
    (ok && after.starts_with(':')).then(|| name.to_string())
}

fn entries(family_dir: &Path, family: &str) -> Vec<Entry> {
    let Ok(dir) = std::fs::read_dir(family_dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = dir
        .map(|e| e.expect("readable directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect();
    files.sort();
    let mut out = Vec::new();
    for path in files {
        let file_name = path.file_name().expect("file name").to_string_lossy();
        let source = format!("crates/yubin-core/src/{family}/{file_name}");
        let e = entry(&path, family, source);
        if e.name.is_some() || e.text.contains("```xml") {
            out.push(e);
        }
    }
    out.sort_by(by_name);
    out
}

/// The documentation entry of the plugin file at `path` of `family`.
fn entry(path: &Path, family: &str, source: String) -> Entry {
    let text = header(&std::fs::read_to_string(path).expect("readable source file"));
    let file_name = path.file_name().expect("file name").to_string_lossy();
    Entry {
        name: type_name(&text),
        source,
        file: format!("{family}/{file_name}"),
        text,
    }
}

/// Named plugins first, by name; multi-plugin files after, by path.
fn by_name(a: &Entry, b: &Entry) -> std::cmp::Ordering {
    match (&a.name, &b.name) {
        (Some(x), Some(y)) => x.cmp(y),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => a.file.cmp(&b.file),
    }
}

fn anchor(tag: &str, e: &Entry) -> String {
    match &e.name {
        Some(n) => format!("{tag}-{n}"),
        None => {
            let stem = e.file.rsplit('/').next().unwrap_or(&e.file);
            format!("{tag}-{}", stem.trim_end_matches(".rs"))
        }
    }
}

fn generate(src: &Path) -> String {
    let families: Vec<(&str, &str, Vec<Entry>)> = FAMILIES
        .iter()
        .map(|&(dir, tag)| {
            let mut list = entries(&src.join(dir), dir);
            for &(family, file) in FRONT_END_PLUGINS.iter().filter(|(f, _)| *f == dir) {
                let path = src.join("../..").join(file);
                list.push(entry(&path, family, format!("crates/{file}")));
            }
            list.sort_by(by_name);
            (dir, tag, list)
        })
        .filter(|(_, _, e)| !e.is_empty())
        .collect();

    let mut md = String::new();
    md.push_str("# Plugin reference\n\n");
    md.push_str(
        "<!-- Generated from the `//!` header of every plugin file in \
         `crates/yubin-core/src/<family>/` (and the front end's `gltf`). Do not edit by hand: change the \
         header and run `YUBIN_UPDATE_DOCS=1 cargo test -p yubin-core --test \
         plugin_docs`. -->\n\n",
    );
    md.push_str(
        "Every plugin a scene file can name, with its parameters and an XML \
         snippet, as its source file documents it. This file is generated \
         from those headers (`crates/yubin-core/tests/plugin_docs.rs`); to \
         change it, edit the header and run\n\n\
         ```sh\nYUBIN_UPDATE_DOCS=1 cargo test -p yubin-core --test plugin_docs\n```\n\n",
    );
    md.push_str("## Contents\n\n");
    for (_, tag, list) in &families {
        let _ = write!(md, "- [{tag}](#{tag}):");
        for (i, e) in list.iter().enumerate() {
            let sep = if i == 0 { " " } else { ", " };
            let label = match &e.name {
                Some(n) => format!("`{n}`"),
                None => format!("`{}`", e.file),
            };
            let _ = write!(md, "{sep}[{label}](#{})", anchor(tag, e));
        }
        md.push('\n');
    }
    md.push_str("- [Coverage of Mitsuba 3.9.1](#coverage)\n\n");
    md.push_str(&coverage());
    for (_, tag, list) in &families {
        let _ = write!(md, "\n<a id=\"{tag}\"></a>\n\n## {tag}\n");
        for e in list {
            let title = match &e.name {
                Some(n) => format!("`{n}`"),
                None => format!("`{}` (several plugins)", e.file),
            };
            let _ = write!(
                md,
                "\n<a id=\"{}\"></a>\n\n### {title}\n\n*Source: `{}`*\n\n{}",
                anchor(tag, e),
                e.source,
                e.text
            );
        }
    }
    md
}

#[test]
fn plugin_reference_is_up_to_date() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let generated = generate(&root.join("src"));
    let doc = root.join("../../docs/plugins.md");
    if std::env::var_os("YUBIN_UPDATE_DOCS").is_some() {
        std::fs::write(&doc, &generated).expect("docs/plugins.md is writable");
        return;
    }
    let current = std::fs::read_to_string(&doc).unwrap_or_default();
    assert!(
        current == generated,
        "docs/plugins.md is stale (or missing): it no longer matches the `//!` \
         headers of the plugin files. Regenerate it with\n    \
         YUBIN_UPDATE_DOCS=1 cargo test -p yubin-core --test plugin_docs"
    );
}

#[test]
fn headers_parse() {
    assert_eq!(type_name("`diffuse`: a\n").as_deref(), Some("diffuse"));
    assert_eq!(type_name("`rough_x2`:\n").as_deref(), Some("rough_x2"));
    assert_eq!(type_name("Pixel filters (`box`): x\n"), None);
    assert_eq!(type_name("`Bvh` is fast\n"), None);
    assert_eq!(
        header("//! `a`: b\n//!\n//!  c\nuse x;\n//! d\n"),
        "`a`: b\n\n c\n"
    );
}
