//! Wavefront OBJ triangle meshes.
//!
//! [`load_obj`] reads the geometry of an `.obj` file (`v`, `vt`, `vn`, `f`)
//! into one [`MeshData`], using [`tobj`] with `single_index` and
//! `triangulate` on.
//!
//! # Conventions
//!
//! | topic | behaviour |
//! |---|---|
//! | vertices | each distinct `v/vt/vn` combination of an object is one vertex (as in Mitsuba) |
//! | polygons | fan-triangulated from their first vertex (`f 1 2 3 4` → `1 2 3`, `1 3 4`) |
//! | objects, groups | `o` and `g` are merged into one mesh (as in Mitsuba) |
//! | indices | 1-based; negative indices count back from the last vertex defined so far |
//! | `flip_tex_coords` | `true` maps `v` → `1 − v` (Mitsuba's default for OBJ is `true`) |
//! | normals, uvs | `Some` only if *every* vertex of every face has one; if some faces have them and others don't, they are dropped for the whole mesh (the renderer then uses geometric normals / no uvs) |
//! | materials | `mtllib` and `usemtl` are ignored: the scene assigns BSDFs |
//! | `v x y z w` | divided by `w`; `v x y z r g b` colours are ignored |
//!
//! In a Mitsuba scene:
//!
//! ```xml
//! <shape type="obj">
//!     <string name="filename" value="meshes/bunny.obj"/>
//!     <boolean name="flip_tex_coords" value="false"/>
//! </shape>
//! ```
//!
//! # Errors
//!
//! A missing or unreadable file is [`SceneError::Io`]. Malformed `v`, `vt`,
//! `vn` or `f` lines and out-of-range indices are reported before `tobj`
//! sees the file, as [`SceneError::At`] with the line, e.g.
//! `bunny.obj:17: face index 42 out of range (the file has 8 vertices)`.
//! A file without any triangle is an error too.
//!
//! # Limitations
//!
//! Lines (`l`), points (`p`) and faces with fewer than three vertices are
//! ignored; curves and free-form surfaces are not supported; polygons are
//! assumed convex (fan triangulation); `\` line continuations are not
//! supported. Positive indices may refer to vertices defined later in the
//! file, as long as they are defined before the next `o`/`g` statement.

use std::borrow::Cow;
use std::io::Cursor;
use std::path::Path;
use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::MeshData;
use crate::error::{Location, SceneError};

/// Loads the triangle mesh of the OBJ file at `path`, merging all objects
/// and groups; `flip_tex_coords` maps `v` → `1 − v`. See the module docs.
pub fn load_obj(path: &Path, flip_tex_coords: bool) -> Result<MeshData, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        error: source,
    })?;
    let file = Arc::new(path.to_path_buf());
    let text = decode_utf8(&bytes, &file)?;
    let counts = scan_vertex_lines(text, &file)?;
    scan_face_lines(text, &file, &counts)?;
    let models = parse_with_tobj(&geometry_only(text), path)?;
    let mesh = merge_models(&models, flip_tex_coords);
    if mesh.indices.is_empty() {
        return Err(SceneError::file(path, "the OBJ file contains no triangles"));
    }
    Ok(mesh)
}

/// The file as UTF-8, or an error naming the first line that is not.
fn decode_utf8<'a>(bytes: &'a [u8], file: &Arc<std::path::PathBuf>) -> Result<&'a str, SceneError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let line = line_of_byte(bytes, e.valid_up_to());
        SceneError::at(&Location::new(file.clone(), line), "not valid UTF-8 text")
    })
}

/// The 1-based line number that contains byte `offset`.
fn line_of_byte(bytes: &[u8], offset: usize) -> u32 {
    let newlines = bytes[..offset.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count();
    u32::try_from(newlines + 1).unwrap_or(u32::MAX)
}

/// Number of `v`, `vt` and `vn` statements, in the whole file or so far.
#[derive(Clone, Copy, Debug, Default)]
struct ElementCounts {
    positions: usize,
    texcoords: usize,
    normals: usize,
}

/// The OBJ lines with their 1-based numbers, split into whitespace-separated words.
fn numbered_lines(text: &str) -> impl Iterator<Item = (u32, std::str::SplitWhitespace<'_>)> {
    text.lines().enumerate().map(|(i, line)| {
        let number = u32::try_from(i + 1).unwrap_or(u32::MAX);
        (number, line.split_whitespace())
    })
}

/// First pass: checks every `v`, `vt`, `vn` line and counts them.
fn scan_vertex_lines(
    text: &str,
    file: &Arc<std::path::PathBuf>,
) -> Result<ElementCounts, SceneError> {
    let mut counts = ElementCounts::default();
    for (line, mut words) in numbered_lines(text) {
        let at = || Location::new(file.clone(), line);
        match words.next() {
            Some("v") => {
                check_position(words).map_err(|msg| SceneError::at(&at(), msg))?;
                counts.positions += 1;
            }
            Some("vt") => {
                check_floats(words, 2, "a texture coordinate needs u and v")
                    .map_err(|msg| SceneError::at(&at(), msg))?;
                counts.texcoords += 1;
            }
            Some("vn") => {
                check_floats(words, 3, "a normal needs three coordinates")
                    .map_err(|msg| SceneError::at(&at(), msg))?;
                counts.normals += 1;
            }
            _ => {}
        }
    }
    Ok(counts)
}

/// Checks the numbers of a `v` line: `x y z`, `x y z w` (w ≠ 0) or `x y z r g b`.
fn check_position(words: std::str::SplitWhitespace<'_>) -> Result<(), String> {
    let values = parse_floats(words)?;
    match values.len() {
        3 | 6 => Ok(()),
        4 if values[3] == 0.0 => Err("vertex with w = 0".into()),
        4 => Ok(()),
        n => Err(format!(
            "a vertex needs 3 coordinates (optionally w, or r g b), found {n} numbers"
        )),
    }
}

/// Checks that a line has at least `needed` numbers (more are ignored, as
/// `tobj` does).
fn check_floats(
    words: std::str::SplitWhitespace<'_>,
    needed: usize,
    what: &str,
) -> Result<(), String> {
    let values = parse_floats(words.take(needed))?;
    if values.len() < needed {
        return Err(format!("{what}, found {} numbers", values.len()));
    }
    Ok(())
}

/// Parses every word as an `f32`, naming the first that is not a number.
fn parse_floats<'a>(words: impl Iterator<Item = &'a str>) -> Result<Vec<f32>, String> {
    words
        .map(|w| {
            w.parse::<f32>()
                .map_err(|_| format!("'{w}' is not a number"))
        })
        .collect()
}

/// Second pass: checks the syntax and every index of every `f` line.
/// Negative indices are resolved against the counts so far, positive ones
/// against the counts of the whole file.
fn scan_face_lines(
    text: &str,
    file: &Arc<std::path::PathBuf>,
    totals: &ElementCounts,
) -> Result<(), SceneError> {
    let mut so_far = ElementCounts::default();
    for (line, mut words) in numbered_lines(text) {
        match words.next() {
            Some("v") => so_far.positions += 1,
            Some("vt") => so_far.texcoords += 1,
            Some("vn") => so_far.normals += 1,
            Some("f") => check_face(words, &so_far, totals)
                .map_err(|msg| SceneError::at(&Location::new(file.clone(), line), msg))?,
            _ => {}
        }
    }
    Ok(())
}

/// Checks one face: `v`, `v/vt`, `v//vn` or `v/vt/vn` per corner.
fn check_face(
    corners: std::str::SplitWhitespace<'_>,
    so_far: &ElementCounts,
    totals: &ElementCounts,
) -> Result<(), String> {
    let mut count = 0;
    for corner in corners {
        count += 1;
        if corner.split('/').count() > 3 {
            return Err(format!(
                "malformed face vertex '{corner}' (expected v, v/vt, v//vn or v/vt/vn)"
            ));
        }
        let kinds = [
            (IndexKind::Position, so_far.positions, totals.positions),
            (IndexKind::Texcoord, so_far.texcoords, totals.texcoords),
            (IndexKind::Normal, so_far.normals, totals.normals),
        ];
        for (part, (kind, so_far, total)) in corner.split('/').zip(kinds) {
            if !(part.is_empty() && kind != IndexKind::Position) {
                check_index(part, corner, kind, so_far, total)?;
            }
        }
    }
    if count == 0 {
        return Err("face without vertices".into());
    }
    Ok(())
}

/// Which array an OBJ index refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum IndexKind {
    Position,
    Texcoord,
    Normal,
}

impl IndexKind {
    /// The index's name in messages.
    fn index_name(self) -> &'static str {
        match self {
            Self::Position => "face index",
            Self::Texcoord => "texture coordinate index",
            Self::Normal => "normal index",
        }
    }

    /// The plural of the element's name in messages.
    fn elements(self) -> &'static str {
        match self {
            Self::Position => "vertices",
            Self::Texcoord => "texture coordinates",
            Self::Normal => "normals",
        }
    }
}

/// Checks one index of a face corner: non-zero; positive ones ≤ `total`;
/// negative ones reach back at most `so_far` elements.
fn check_index(
    part: &str,
    corner: &str,
    kind: IndexKind,
    so_far: usize,
    total: usize,
) -> Result<(), String> {
    let index: i64 = part
        .parse()
        .map_err(|_| format!("malformed face vertex '{corner}'"))?;
    let name = kind.index_name();
    let elements = kind.elements();
    if index == 0 {
        Err(format!("{name} 0 is invalid (OBJ indices start at 1)"))
    } else if index > 0 && index.unsigned_abs() > total as u64 {
        Err(format!(
            "{name} {index} out of range (the file has {total} {elements})"
        ))
    } else if index < 0 && index.unsigned_abs() > so_far as u64 {
        Err(format!(
            "{name} {index} out of range ({so_far} {elements} precede this line)"
        ))
    } else {
        Ok(())
    }
}

/// The text as `tobj` should see it: statements that don't concern the
/// geometry (`l`, `usemtl`, `mtllib`) blanked, so that `tobj` neither turns
/// polylines into triangles, splits meshes by material nor opens `.mtl`
/// files; and vertex colours cut off, since `tobj` fails when only some
/// vertices have them. Line structure is kept. Borrows when nothing changes.
fn geometry_only(text: &str) -> Cow<'_, str> {
    if !text.lines().any(|line| rewritten(line).is_some()) {
        return Cow::Borrowed(text);
    }
    let mut kept = String::with_capacity(text.len());
    for line in text.lines() {
        kept.push_str(rewritten(line).unwrap_or(line));
        kept.push('\n');
    }
    Cow::Owned(kept)
}

/// What `tobj` should see instead of `line`, if not `line` itself: nothing
/// for `l`, `usemtl` and `mtllib`; `v x y z` for `v x y z r g b`.
fn rewritten(line: &str) -> Option<&str> {
    let mut words = line.split_whitespace();
    match words.next() {
        Some("l" | "usemtl" | "mtllib") => Some(""),
        Some("v") if words.clone().count() == 6 => {
            let z = words.nth(2)?;
            // `z` is a slice of `line`: keep everything up to its end.
            let end = z.as_ptr() as usize - line.as_ptr() as usize + z.len();
            line.get(..end)
        }
        _ => None,
    }
}

/// Runs `tobj` on the (already checked) text.
fn parse_with_tobj(text: &str, path: &Path) -> Result<Vec<tobj::Model>, SceneError> {
    // tobj's optional features add fields; the update keeps this compiling
    // when another crate enables them.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let no_materials = |_: &Path| Ok((Vec::new(), Default::default()));
    let (models, _) = tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &options, no_materials)
        .map_err(|e| SceneError::file(path, format!("invalid OBJ file: {e}")))?;
    Ok(models)
}

/// Concatenates the models into one mesh, offsetting their indices.
fn merge_models(models: &[tobj::Model], flip_tex_coords: bool) -> MeshData {
    let meshes: Vec<&tobj::Mesh> = models
        .iter()
        .map(|m| &m.mesh)
        .filter(|m| !m.indices.is_empty())
        .collect();
    let all_have_normals = meshes.iter().all(|m| m.normals.len() == m.positions.len());
    let all_have_uvs = meshes
        .iter()
        .all(|m| m.texcoords.len() / 2 == m.positions.len() / 3);
    let mut out = MeshData {
        normals: all_have_normals.then(Vec::new),
        uvs: all_have_uvs.then(Vec::new),
        ..Default::default()
    };
    for mesh in meshes {
        append_mesh(&mut out, mesh, flip_tex_coords);
    }
    out
}

/// Appends one `tobj` mesh to `out`; normals and uvs only where `out` keeps them.
fn append_mesh(out: &mut MeshData, mesh: &tobj::Mesh, flip_tex_coords: bool) {
    let offset = out.positions.len() as u32;
    out.positions
        .extend(mesh.positions.chunks_exact(3).map(Vec3::from_slice));
    if let Some(normals) = &mut out.normals {
        normals.extend(mesh.normals.chunks_exact(3).map(Vec3::from_slice));
    }
    if let Some(uvs) = &mut out.uvs {
        uvs.extend(mesh.texcoords.chunks_exact(2).map(|t| {
            let v = if flip_tex_coords { 1.0 - t[1] } else { t[1] };
            Vec2::new(t[0], v)
        }));
    }
    out.indices.extend(
        mesh.indices
            .chunks_exact(3)
            .map(|t| [t[0] + offset, t[1] + offset, t[2] + offset]),
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Writes `contents` to a fresh file in the temp directory.
    fn temp_obj(contents: &str) -> PathBuf {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let path =
            std::env::temp_dir().join(format!("yubin-obj-test-{}-{n}.obj", std::process::id()));
        std::fs::write(&path, contents).expect("write temp file");
        path
    }

    /// Loads `contents` as an OBJ file and removes the file again.
    fn load_str(contents: &str, flip: bool) -> Result<MeshData, SceneError> {
        let path = temp_obj(contents);
        let result = load_obj(&path, flip);
        let _ = std::fs::remove_file(&path);
        result
    }

    const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

    #[test]
    fn quad_becomes_two_triangles() {
        let mesh = load_str(&format!("{QUAD}f 1 2 3 4\n"), true).unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(mesh.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert!(mesh.normals.is_none());
        assert!(mesh.uvs.is_none());
    }

    #[test]
    fn pentagon_is_fan_triangulated() {
        let obj = "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nf 1 2 3 4 5\n";
        let mesh = load_str(obj, true).unwrap();
        assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }

    #[test]
    fn normals_and_uvs_are_kept() {
        let obj = format!(
            "{QUAD}vt 0 0\nvt 1 0\nvt 1 1\nvt 0 0.25\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n"
        );
        let mesh = load_str(&obj, false).unwrap();
        let normals = mesh.normals.unwrap();
        let uvs = mesh.uvs.unwrap();
        assert_eq!(normals.len(), 4);
        assert!(normals.iter().all(|&n| n == Vec3::Z));
        assert_eq!(uvs[3], Vec2::new(0.0, 0.25));
    }

    #[test]
    fn flip_tex_coords_maps_v_to_one_minus_v() {
        let obj = format!("{QUAD}vt 0 0\nvt 1 0\nvt 1 1\nvt 0 0.25\nf 1/1 2/2 3/3 4/4\n");
        let mesh = load_str(&obj, true).unwrap();
        assert!(mesh.normals.is_none());
        let uvs = mesh.uvs.unwrap();
        assert_eq!(uvs[0], Vec2::new(0.0, 1.0));
        assert_eq!(uvs[3], Vec2::new(0.0, 0.75));
    }

    #[test]
    fn distinct_corner_combinations_are_distinct_vertices() {
        // Two triangles share positions 1 and 3 but with different normals.
        let obj = format!("{QUAD}vn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1\nf 1//2 3//2 4//2\n");
        let mesh = load_str(&obj, true).unwrap();
        assert_eq!(mesh.positions.len(), 6);
        assert_eq!(mesh.normals.unwrap().len(), 6);
    }

    #[test]
    fn partial_normals_are_dropped() {
        let obj = format!("{QUAD}vn 0 0 1\nf 1//1 2//1 3//1\nf 1 3 4\n");
        let mesh = load_str(&obj, true).unwrap();
        assert_eq!(mesh.indices.len(), 2);
        assert!(mesh.normals.is_none());
    }

    #[test]
    fn negative_indices_are_relative() {
        let obj = format!("{QUAD}vt 0 0\nvt 1 1\nf -4/-2 -3/-1 -2/-1 -1/-1\n");
        let mesh = load_str(&obj, false).unwrap();
        assert_eq!(mesh.indices.len(), 2);
        assert_eq!(mesh.positions[0], Vec3::ZERO);
        assert_eq!(mesh.uvs.unwrap()[0], Vec2::ZERO);
    }

    #[test]
    fn objects_and_groups_are_merged() {
        let obj = format!(
            "o first\n{QUAD}usemtl red\nf 1 2 3\ng second\nusemtl blue\nf 1 3 4\nl 1 2 3\n"
        );
        let mesh = load_str(&obj, true).unwrap();
        assert_eq!(mesh.indices.len(), 2);
        assert_eq!(mesh.positions.len(), 6);
        for tri in &mesh.indices {
            assert!(tri.iter().all(|&i| (i as usize) < mesh.positions.len()));
        }
    }

    #[test]
    fn out_of_range_index_names_file_and_line() {
        let path = temp_obj(&format!("# comment\n{QUAD}f 1 2 3\nf 1 2 42\n"));
        let err = load_obj(&path, true).unwrap_err().to_string();
        let _ = std::fs::remove_file(&path);
        let expected = format!(
            "{}:7: face index 42 out of range (the file has 4 vertices)",
            path.display()
        );
        assert_eq!(err, expected);
    }

    #[test]
    fn bad_relative_and_zero_indices_are_errors() {
        let err = load_str(&format!("{QUAD}f -5 1 2\n"), true).unwrap_err();
        assert!(
            err.to_string().contains(":5: face index -5 out of range"),
            "{err}"
        );
        let err = load_str(&format!("{QUAD}f 0 1 2\n"), true).unwrap_err();
        assert!(
            err.to_string().contains(":5: face index 0 is invalid"),
            "{err}"
        );
        let err = load_str(&format!("{QUAD}vn 0 0 1\nf 1//2 2//1 3//1\n"), true).unwrap_err();
        assert!(
            err.to_string().contains(":6: normal index 2 out of range"),
            "{err}"
        );
        let err = load_str(&format!("{QUAD}f 1/1 2/1 3/1\n"), true).unwrap_err();
        assert!(
            err.to_string().contains(":5: texture coordinate index 1"),
            "{err}"
        );
    }

    #[test]
    fn malformed_lines_name_the_line() {
        let cases = [
            ("v 0 0 0\nv 1 x 0\n", ":2: 'x' is not a number"),
            ("v 0 0\n", ":1: a vertex needs 3 coordinates"),
            ("v 0 0 0 0\n", ":1: vertex with w = 0"),
            ("vt 0.5\n", ":1: a texture coordinate needs u and v"),
            ("vn 0 1\n", ":1: a normal needs three coordinates"),
            (
                "v 0 0 0\nf 1/1/1/1 1 1\n",
                ":2: malformed face vertex '1/1/1/1'",
            ),
            ("v 0 0 0\nf a b c\n", ":2: malformed face vertex 'a'"),
            ("v 0 0 0\n\nf\n", ":3: face without vertices"),
        ];
        for (obj, expected) in cases {
            let err = load_str(obj, true).unwrap_err().to_string();
            assert!(err.contains(expected), "{obj:?}: {err}");
        }
    }

    #[test]
    fn vertex_colours_are_ignored_even_when_only_some_vertices_have_them() {
        let obj = "v 0 0 0 1 0 0\nv 1 0 0\nv 1 1 0 0 0 1\nl 1 2\nf 1 2 3\n";
        let mesh = load_str(obj, true).unwrap();
        assert_eq!(
            mesh.positions,
            [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)]
        );
        assert_eq!(rewritten("v 1 2 3 0.5 0.5 0.5"), Some("v 1 2 3"));
        assert_eq!(rewritten("  v\t1 2 3 4"), None);
    }

    #[test]
    fn file_without_faces_is_an_error() {
        let err = load_str(QUAD, true).unwrap_err();
        assert!(err.to_string().contains("no triangles"), "{err}");
    }

    #[test]
    fn invalid_utf8_names_the_line() {
        let path = temp_obj("");
        std::fs::write(&path, b"v 0 0 0\n# \xff\xfe\n").unwrap();
        let err = load_obj(&path, true).unwrap_err().to_string();
        let _ = std::fs::remove_file(&path);
        assert!(err.contains(":2: not valid UTF-8"), "{err}");
    }

    #[test]
    fn missing_file_is_an_io_error_with_the_path() {
        let path = std::env::temp_dir().join("yubin-obj-test-does-not-exist.obj");
        let err = load_obj(&path, true).unwrap_err();
        assert!(matches!(err, SceneError::Io { .. }));
        assert!(err
            .to_string()
            .contains("yubin-obj-test-does-not-exist.obj"));
    }

    #[test]
    fn shared_mitsuba_obj_files_load() {
        let dir = crate::shared_path("mitsuba-data/tests/obj");
        let Ok(entries) = std::fs::read_dir(&dir) else {
            println!("skipped: {} not found", dir.display());
            return;
        };
        let mut loaded = 0;
        for entry in entries.flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "obj") {
                let mesh = load_obj(&path, true).unwrap_or_else(|e| panic!("{e}"));
                assert!(!mesh.indices.is_empty(), "{}", path.display());
                loaded += 1;
            }
        }
        assert!(loaded >= 4, "only {loaded} OBJ files found");
        let mesh = load_obj(&dir.join("rectangle_normals_uv.obj"), true).unwrap();
        assert_eq!((mesh.positions.len(), mesh.indices.len()), (4, 2));
        assert!(mesh.normals.is_some() && mesh.uvs.is_some());
        let smallbox = load_obj(&dir.join("cbox_smallbox.obj"), true).unwrap();
        assert_eq!((smallbox.positions.len(), smallbox.indices.len()), (24, 12));
    }
}
