//! Stanford PLY triangle meshes.
//!
//! [`load_ply`] reads the `vertex` and `face` elements of a PLY file
//! (`ascii`, `binary_little_endian` or `binary_big_endian`) into one
//! [`MeshData`]. The header and the rows are decoded by [`ply_rs_bw`];
//! this module picks the properties it needs and checks them.
//!
//! # What is read
//!
//! | element | properties | notes |
//! |---|---|---|
//! | `vertex` | `x`, `y`, `z` | required; any scalar type |
//! | `vertex` | `nx`, `ny`, `nz` | optional; used only when all three are present |
//! | `vertex` | `u`,`v` / `s`,`t` / `texture_u`,`texture_v` / `texture_s`,`texture_t` | optional; the first complete pair in this order; no flip |
//! | `face` | `vertex_indices` or `vertex_index` | a list of any integer type and any arity; fan-triangulated from its first vertex |
//! | `vertex`, `face` | any other scalar | named attributes `vertex_<name>` / `face_<name>`, below |
//!
//! Other elements are skipped. Faces with fewer than three vertices are
//! ignored.
//!
//! ## Attributes
//!
//! As Mitsuba 3 (3.9.1, checked) names them: `r`, `g`, `b` (and `a`) or
//! `red`, `green`, `blue` (and `alpha`) form the attribute `color`;
//! `<name>_0`, `<name>_1`, … form `<name>`, channels in header order. One or
//! three channels are kept (four for a colour with alpha); other counts,
//! names without a `_<digit>` suffix and list properties are skipped.
//! Values: `float`/`double` and `uchar` as they are (so 8-bit colours are
//! 0–255, as in Mitsuba, which warns about it); other integer types divided
//! by their largest value and decoded from sRGB. A face attribute of a
//! polygon is repeated for each of its triangles (Mitsuba rejects
//! polygons with face attributes).
//!
//! In a Mitsuba scene:
//!
//! ```xml
//! <shape type="ply">
//!     <string name="filename" value="meshes/bunny.ply"/>
//! </shape>
//! ```
//!
//! # Errors
//!
//! A missing or unreadable file is [`SceneError::Io`]. A bad header, a
//! missing `x`/`y`/`z`, a truncated file and an index out of range name the
//! file, and for ASCII files the line (`mesh.ply:12: ...`); for binary files
//! the message names the element row instead (`face 17 of 69451`).
//!
//! # Limitations
//!
//! ASCII files need one element per line (as every writer produces);
//! ASCII numbers follow `ply-rs-bw`'s grammar (no `nan`, `inf` or `1.`).
//! Point clouds (no faces) are rejected. Polygons are assumed convex.

use std::io::{self, BufRead};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Vec2, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, Property, PropertyAccess, PropertyType, ScalarType,
};

use super::MeshData;
use crate::error::{Location, SceneError};
use yubin_core::shape::PropertyTable;
use yubin_core::texture::image::srgb_to_linear;
use yubin_core::texture::NamedAttribute;

/// Names of texture coordinate pairs, tried in this order.
const UV_NAMES: [(&str, &str); 4] = [
    ("u", "v"),
    ("s", "t"),
    ("texture_u", "texture_v"),
    ("texture_s", "texture_t"),
];

/// Names of the face property holding the vertex indices.
const FACE_INDEX_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];

/// Loads the triangle mesh of the PLY file at `path`. See the module docs.
pub fn load_ply(path: &Path) -> Result<MeshData, SceneError> {
    with_rows(path, |header, rows| {
        let layout = MeshLayout::from_header(header, &rows.file)?;
        read_mesh(rows, header, &layout)
    })
}

/// The first element of the PLY file at `path` as a table of `float`
/// properties, as Mitsuba 3's `ellipsoids` read their Gaussians: any other
/// property type is an error naming it (Mitsuba would read its bytes as
/// floats).
pub fn load_ply_table(path: &Path) -> Result<PropertyTable, SceneError> {
    with_rows(path, |header, rows| {
        let element = header
            .elements
            .values()
            .next()
            .ok_or_else(|| rows.file_error("the PLY header declares no element".into()))?;
        let mut names = Vec::new();
        for (name, p) in element.properties.iter() {
            let kind = match &p.data_type {
                PropertyType::Scalar(ScalarType::Float) => None,
                PropertyType::Scalar(t) => Some(format!("{t:?}").to_lowercase()),
                PropertyType::List(..) => Some("a list".to_string()),
            };
            if let Some(kind) = kind {
                return Err(rows.file_error(format!(
                    "property '{name}' of '{}' is {kind}: every property must be a float (float32)",
                    element.name
                )));
            }
            names.push(name.clone());
        }
        let mut values = Vec::with_capacity(rows.plausible_capacity(element.count) * names.len());
        for index in 0..element.count {
            let row = rows.next_row(element, index)?;
            values.extend(row.0.iter().map(scalar_f32));
        }
        Ok(PropertyTable {
            names,
            rows: element.count,
            values,
        })
    })
}

/// Reads the header of the PLY file at `path` and calls `read` with it
/// and a reader of its rows.
fn with_rows<T>(
    path: &Path,
    read: impl FnOnce(&Header, &mut RowReader) -> Result<T, SceneError>,
) -> Result<T, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        error: source,
    })?;
    let file = Arc::new(path.to_path_buf());
    check_header_numbers(&bytes, &file)?;
    let parser = Parser::<Row>::new();
    let mut body: &[u8] = &bytes;
    let header = parser
        .read_header(&mut body)
        .map_err(|e| header_error(&file, &e))?;
    let header_lines = count_newlines(&bytes[..bytes.len() - body.len()]);
    let mut rows = RowReader {
        parser,
        encoding: header.encoding,
        body,
        file,
        line: header_lines + 1,
    };
    read(&header, &mut rows)
}

/// One element row: its property values in header order.
#[derive(Debug)]
struct Row(Vec<Property>);

impl PropertyAccess for Row {
    fn new() -> Self {
        Row(Vec::with_capacity(4))
    }

    fn set_property(&mut self, _name: String, property: Property) {
        // ply-rs-bw sets the properties in header order, so the position in
        // the vector is the column found by `column`.
        self.0.push(property);
    }
}

/// Where the wanted properties are in the `vertex` and `face` rows.
#[derive(Debug)]
struct MeshLayout {
    vertex_count: usize,
    position: [usize; 3],
    normal: Option<[usize; 3]>,
    uv: Option<[usize; 2]>,
    face_indices: usize,
    vertex_attributes: Vec<AttributeColumns>,
    face_attributes: Vec<AttributeColumns>,
}

/// The columns of one named attribute.
#[derive(Debug)]
struct AttributeColumns {
    /// `vertex_<name>` or `face_<name>`.
    name: String,
    columns: Vec<usize>,
}

/// The attribute a colour property belongs to.
const COLOR_NAMES: [&str; 8] = ["r", "g", "b", "a", "red", "green", "blue", "alpha"];

/// Groups the scalar properties of `element` not in `used` into named
/// attributes (see the module docs).
fn attribute_columns(element: &ElementDef, prefix: &str, used: &[usize]) -> Vec<AttributeColumns> {
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for (column, (key, p)) in element.properties.iter().enumerate() {
        if used.contains(&column) || !matches!(p.data_type, PropertyType::Scalar(_)) {
            continue;
        }
        let group = if COLOR_NAMES.contains(&key.as_str()) {
            "color"
        } else {
            match key.rsplit_once('_') {
                Some((base, digits))
                    if !base.is_empty()
                        && !digits.is_empty()
                        && digits.bytes().all(|b| b.is_ascii_digit()) =>
                {
                    base
                }
                _ => continue,
            }
        };
        match groups.iter_mut().find(|g| g.0 == group) {
            Some(g) => g.1.push(column),
            None => groups.push((group.to_string(), vec![column])),
        }
    }
    groups
        .into_iter()
        .filter(|(name, columns)| {
            matches!(columns.len(), 1 | 3) || (name == "color" && columns.len() == 4)
        })
        .map(|(name, columns)| AttributeColumns {
            name: format!("{prefix}_{name}"),
            columns,
        })
        .collect()
}

impl MeshLayout {
    /// Finds the columns, or says what the header lacks.
    fn from_header(header: &Header, file: &Arc<PathBuf>) -> Result<Self, SceneError> {
        let whole_file = |msg: String| SceneError::at(&Location::new(file.clone(), 0), msg);
        let vertex = header
            .elements
            .get("vertex")
            .ok_or_else(|| whole_file("PLY file has no 'vertex' element".into()))?;
        let face = header.elements.get("face").ok_or_else(|| {
            whole_file("PLY file has no 'face' element (point clouds are not supported)".into())
        })?;
        let position = scalar_columns(vertex, ["x", "y", "z"]).map_err(|missing| {
            whole_file(format!(
                "PLY vertex element has no scalar '{missing}' property"
            ))
        })?;
        let normal = scalar_columns(vertex, ["nx", "ny", "nz"]).ok();
        let uv = UV_NAMES
            .iter()
            .find_map(|&(u, v)| scalar_columns(vertex, [u, v]).ok());
        let face_indices = FACE_INDEX_NAMES
            .iter()
            .find_map(|name| integer_list_column(face, name))
            .ok_or_else(|| {
                whole_file(
                    "PLY face element has no integer list 'vertex_indices' or 'vertex_index'"
                        .into(),
                )
            })?;
        if vertex.count > u32::MAX as usize {
            return Err(whole_file(format!("too many vertices ({})", vertex.count)));
        }
        let mut used: Vec<usize> = position.to_vec();
        used.extend(normal.into_iter().flatten());
        for (u, v) in UV_NAMES {
            if let Ok(columns) = scalar_columns(vertex, [u, v]) {
                used.extend(columns);
            }
        }
        Ok(Self {
            vertex_count: vertex.count,
            position,
            normal,
            uv,
            face_indices,
            vertex_attributes: attribute_columns(vertex, "vertex", &used),
            face_attributes: attribute_columns(face, "face", &[face_indices]),
        })
    }
}

/// The columns of the scalar properties `names`, or the first missing name.
fn scalar_columns<const N: usize>(
    element: &ElementDef,
    names: [&'static str; N],
) -> Result<[usize; N], &'static str> {
    let mut columns = [0; N];
    for (column, name) in columns.iter_mut().zip(names) {
        *column = element
            .properties
            .iter()
            .position(|(key, p)| key == name && matches!(p.data_type, PropertyType::Scalar(_)))
            .ok_or(name)?;
    }
    Ok(columns)
}

/// The column of the integer list property `name`, if there is one.
fn integer_list_column(element: &ElementDef, name: &str) -> Option<usize> {
    element.properties.iter().position(|(key, p)| {
        key == name && matches!(&p.data_type, PropertyType::List(_, t) if !matches!(t, ScalarType::Float | ScalarType::Double))
    })
}

/// Reads the rows of every element up to the last one the mesh needs.
fn read_mesh(
    rows: &mut RowReader,
    header: &Header,
    layout: &MeshLayout,
) -> Result<MeshData, SceneError> {
    let mut mesh = MeshData {
        normals: layout.normal.map(|_| Vec::new()),
        uvs: layout.uv.map(|_| Vec::new()),
        attributes: layout
            .vertex_attributes
            .iter()
            .chain(&layout.face_attributes)
            .map(|a| NamedAttribute {
                name: a.name.clone(),
                channels: a.columns.len() as u8,
                values: Vec::new(),
            })
            .collect(),
        ..Default::default()
    };
    let (mut have_vertices, mut have_faces) = (false, false);
    for element in header.elements.values() {
        match element.name.as_str() {
            "vertex" => {
                read_vertices(rows, element, layout, &mut mesh)?;
                have_vertices = true;
            }
            "face" => {
                read_faces(rows, element, layout, &mut mesh)?;
                have_faces = true;
            }
            _ => skip_rows(rows, element)?,
        }
        if have_vertices && have_faces {
            break;
        }
    }
    if mesh.indices.is_empty() {
        return Err(rows.file_error("the PLY file contains no triangles".into()));
    }
    Ok(mesh)
}

/// Reads all `vertex` rows into positions, normals and uvs.
fn read_vertices(
    rows: &mut RowReader,
    element: &ElementDef,
    layout: &MeshLayout,
    mesh: &mut MeshData,
) -> Result<(), SceneError> {
    let capacity = rows.plausible_capacity(element.count);
    mesh.positions.reserve(capacity);
    for index in 0..element.count {
        let row = rows.next_row(element, index)?;
        let [x, y, z] = layout.position.map(|c| scalar_f32(&row.0[c]));
        mesh.positions.push(Vec3::new(x, y, z));
        if let (Some(normals), Some(cols)) = (&mut mesh.normals, layout.normal) {
            let [nx, ny, nz] = cols.map(|c| scalar_f32(&row.0[c]));
            normals.push(Vec3::new(nx, ny, nz));
        }
        if let (Some(uvs), Some(cols)) = (&mut mesh.uvs, layout.uv) {
            let [u, v] = cols.map(|c| scalar_f32(&row.0[c]));
            uvs.push(Vec2::new(u, v));
        }
        for (a, out) in layout.vertex_attributes.iter().zip(&mut mesh.attributes) {
            out.values
                .extend(a.columns.iter().map(|&c| attribute_value(&row.0[c])));
        }
    }
    Ok(())
}

/// Reads all `face` rows, fan-triangulating each polygon.
fn read_faces(
    rows: &mut RowReader,
    element: &ElementDef,
    layout: &MeshLayout,
    mesh: &mut MeshData,
) -> Result<(), SceneError> {
    mesh.indices.reserve(rows.plausible_capacity(element.count));
    let mut polygon = Vec::new();
    for index in 0..element.count {
        let line = rows.line;
        let row = rows.next_row(element, index)?;
        list_as_i64(&row.0[layout.face_indices], &mut polygon);
        if let Some(&bad) = polygon
            .iter()
            .find(|&&i| i < 0 || i >= layout.vertex_count as i64)
        {
            let msg = format!(
                "face {index}: vertex index {bad} out of range (the file has {} vertices)",
                layout.vertex_count
            );
            return Err(rows.error_at(line, msg));
        }
        let before = mesh.indices.len();
        fan_triangulate(&polygon, &mut mesh.indices);
        let triangles = mesh.indices.len() - before;
        let face_outputs = &mut mesh.attributes[layout.vertex_attributes.len()..];
        for (a, out) in layout.face_attributes.iter().zip(face_outputs) {
            for _ in 0..triangles {
                out.values
                    .extend(a.columns.iter().map(|&c| attribute_value(&row.0[c])));
            }
        }
    }
    Ok(())
}

/// Reads and drops the rows of an element the mesh doesn't use.
fn skip_rows(rows: &mut RowReader, element: &ElementDef) -> Result<(), SceneError> {
    for index in 0..element.count {
        rows.next_row(element, index)?;
    }
    Ok(())
}

/// Appends the triangles `(p0, p[i], p[i+1])` of a polygon already checked
/// to hold valid `u32` indices; fewer than three vertices give nothing.
fn fan_triangulate(polygon: &[i64], out: &mut Vec<[u32; 3]>) {
    if let Some((&first, rest)) = polygon.split_first() {
        out.extend(
            rest.windows(2)
                .map(|w| [first as u32, w[0] as u32, w[1] as u32]),
        );
    }
}

/// A scalar property as `f32` (the layout guarantees it is a scalar).
fn scalar_f32(property: &Property) -> f32 {
    match *property {
        Property::Char(v) => v as f32,
        Property::UChar(v) => v as f32,
        Property::Short(v) => v as f32,
        Property::UShort(v) => v as f32,
        Property::Int(v) => v as f32,
        Property::UInt(v) => v as f32,
        Property::Float(v) => v,
        Property::Double(v) => v as f32,
        _ => f32::NAN,
    }
}

/// A scalar property as an attribute value, scaled as Mitsuba 3 does:
/// floats and `uchar` as they are, other integers divided by their largest
/// value and decoded from sRGB.
fn attribute_value(property: &Property) -> f32 {
    let normalized = match *property {
        Property::Char(v) => f64::from(v) / f64::from(i8::MAX),
        Property::Short(v) => f64::from(v) / f64::from(i16::MAX),
        Property::UShort(v) => f64::from(v) / f64::from(u16::MAX),
        Property::Int(v) => f64::from(v) / f64::from(i32::MAX),
        Property::UInt(v) => f64::from(v) / f64::from(u32::MAX),
        _ => return scalar_f32(property),
    };
    srgb_to_linear(normalized as f32)
}

/// An integer list property as `i64`s in `out` (cleared first).
fn list_as_i64(property: &Property, out: &mut Vec<i64>) {
    out.clear();
    match property {
        Property::ListChar(l) => out.extend(l.iter().map(|&i| i64::from(i))),
        Property::ListUChar(l) => out.extend(l.iter().map(|&i| i64::from(i))),
        Property::ListShort(l) => out.extend(l.iter().map(|&i| i64::from(i))),
        Property::ListUShort(l) => out.extend(l.iter().map(|&i| i64::from(i))),
        Property::ListInt(l) => out.extend(l.iter().map(|&i| i64::from(i))),
        Property::ListUInt(l) => out.extend(l.iter().map(|&i| i64::from(i))),
        _ => {}
    }
}

/// Decodes element rows one at a time and knows where it is in the file.
struct RowReader<'a> {
    parser: Parser<Row>,
    encoding: Encoding,
    body: &'a [u8],
    file: Arc<PathBuf>,
    /// The 1-based line of the next ASCII row.
    line: u32,
}

impl std::fmt::Debug for RowReader<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RowReader")
            .field("encoding", &self.encoding)
            .field("remaining", &self.body.len())
            .field("line", &self.line)
            .finish()
    }
}

impl RowReader<'_> {
    /// Decodes row `index` of `element`.
    fn next_row(&mut self, element: &ElementDef, index: usize) -> Result<Row, SceneError> {
        let result = match self.encoding {
            Encoding::Ascii => self.next_ascii_row(element),
            Encoding::BinaryLittleEndian => self
                .parser
                .read_little_endian_element(&mut self.body, element),
            Encoding::BinaryBigEndian => {
                self.parser.read_big_endian_element(&mut self.body, element)
            }
        };
        result.map_err(|e| self.row_error(element, index, &e))
    }

    /// Reads one line and decodes it as a row.
    fn next_ascii_row(&mut self, element: &ElementDef) -> io::Result<Row> {
        let mut text = String::new();
        if self.body.read_line(&mut text)? == 0 {
            return Err(io::ErrorKind::UnexpectedEof.into());
        }
        let row = self.parser.read_ascii_element(&text, element)?;
        self.line += 1;
        Ok(row)
    }

    /// The error for a row that could not be decoded.
    fn row_error(&self, element: &ElementDef, index: usize, e: &io::Error) -> SceneError {
        let which = format!("{} {index} of {}", element.name, element.count);
        let truncated = self.body.is_empty() || e.kind() == io::ErrorKind::UnexpectedEof;
        let msg = if truncated {
            format!("file is truncated: it ends in {which}")
        } else {
            format!("{which}: {}", concise(e))
        };
        match self.encoding {
            Encoding::Ascii => self.error_at(self.line, msg),
            _ => self.file_error(msg),
        }
    }

    /// An error at `line` for ASCII files, about the whole file otherwise.
    fn error_at(&self, line: u32, msg: String) -> SceneError {
        match self.encoding {
            Encoding::Ascii => SceneError::at(&Location::new(self.file.clone(), line), msg),
            _ => self.file_error(msg),
        }
    }

    /// An error about the whole file.
    fn file_error(&self, msg: String) -> SceneError {
        SceneError::file(self.file.as_path(), msg)
    }

    /// How many rows are worth reserving: at most one per remaining byte, so
    /// that a header claiming billions of rows can't exhaust memory.
    fn plausible_capacity(&self, count: usize) -> usize {
        count.min(self.body.len())
    }
}

/// Rejects `element` and `format` header lines whose numbers would overflow
/// (ply-rs-bw panics on those).
fn check_header_numbers(bytes: &[u8], file: &Arc<PathBuf>) -> Result<(), SceneError> {
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        if line.starts_with(b"end_header") {
            break;
        }
        let counted = line.starts_with(b"element") || line.starts_with(b"format");
        let longest_digit_run = line
            .split(|b| !b.is_ascii_digit())
            .map(<[u8]>::len)
            .max()
            .unwrap_or(0);
        if counted && longest_digit_run > 18 {
            let line_number = u32::try_from(i + 1).unwrap_or(u32::MAX);
            return Err(SceneError::at(
                &Location::new(file.clone(), line_number),
                "number too large in PLY header",
            ));
        }
    }
    Ok(())
}

/// A header error from ply-rs-bw (`Line N: message\n\tdetails`) as a
/// located error.
fn header_error(file: &Arc<PathBuf>, e: &io::Error) -> SceneError {
    let message = concise(e);
    let located = message
        .strip_prefix("Line ")
        .and_then(|rest| rest.split_once(": "))
        .and_then(|(n, msg)| Some((n.parse::<u32>().ok()?, msg.to_string())));
    match located {
        Some((line, msg)) => SceneError::at(
            &Location::new(file.clone(), line),
            format!("invalid PLY header: {msg}"),
        ),
        None => SceneError::file(file.as_path(), format!("invalid PLY header: {message}")),
    }
}

/// The first line of a ply-rs-bw error message, plus its `String:`/`Value:`
/// detail if it has one.
fn concise(e: &io::Error) -> String {
    let text = e.to_string();
    let mut lines = text.lines().map(str::trim);
    let first = lines.next().unwrap_or_default().to_string();
    match lines.find(|l| l.starts_with("Value:") || l.starts_with("String:")) {
        Some(detail) => format!("{first} ({detail})"),
        None => first,
    }
}

/// Number of `\n` in `bytes`, as a line count.
fn count_newlines(bytes: &[u8]) -> u32 {
    let n = bytes.iter().filter(|&&b| b == b'\n').count();
    u32::try_from(n).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A fresh path in the temp directory.
    fn temp_path() -> PathBuf {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        std::env::temp_dir().join(format!("yubin-ply-test-{}-{n}.ply", std::process::id()))
    }

    /// Loads `contents` as a PLY file and removes the file again.
    fn load_bytes(contents: &[u8]) -> Result<MeshData, SceneError> {
        let path = temp_path();
        std::fs::write(&path, contents).expect("write temp file");
        let result = load_ply(&path);
        let _ = std::fs::remove_file(&path);
        result
    }

    const ASCII_QUAD: &str = "ply
format ascii 1.0
comment a unit quad with normals, uvs and colours
element vertex 4
property float x
property float y
property float z
property float nx
property float ny
property float nz
property float s
property float t
property uchar red
element face 1
property list uchar int vertex_indices
property uchar red
end_header
0 0 0 0 0 1 0 0 255
1 0 0 0 0 1 1 0 255
1 1 0 0 0 1 1 1 255
0 1 0 0 0 1 0 1 255
4 0 1 2 3 7
";

    #[test]
    fn ascii_quad_with_normals_and_uvs() {
        let mesh = load_bytes(ASCII_QUAD.as_bytes()).unwrap();
        assert_eq!(mesh.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(mesh.normals.unwrap(), vec![Vec3::Z; 4]);
        assert_eq!(mesh.uvs.unwrap()[3], Vec2::new(0.0, 1.0));
    }

    /// Attributes named and scaled as Mitsuba 3.9.1 does (values checked
    /// there with `mi.traverse(shape)` on the same kinds of properties).
    #[test]
    fn extra_properties_become_named_attributes() {
        let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                   property float z\nproperty float u\nproperty float v\nproperty uchar red\n\
                   property uchar green\nproperty uchar blue\nproperty char w_0\nproperty ushort q_0\n\
                   property float temp\nproperty float two_0\nproperty float two_1\n\
                   element face 2\nproperty list uchar int vertex_indices\nproperty double color_0\n\
                   property double color_1\nproperty double color_2\nend_header\n\
                   0 0 0 0 0 255 128 0 64 32768 5 1 2\n1 0 0 1 0 0 0 0 -64 6553 5 1 2\n\
                   0 1 0 0 1 1 2 3 127 65535 5 1 2\n3 0 1 2 0.5 2 -1\n4 0 1 2 0 0.1 0.2 0.3\n";
        let mesh = load_bytes(ply.as_bytes()).unwrap();
        let names: Vec<&str> = mesh.attributes.iter().map(|a| a.name.as_str()).collect();
        // `temp` has no suffix and `two` two channels: both skipped.
        assert_eq!(
            names,
            ["vertex_color", "vertex_w", "vertex_q", "face_color"]
        );
        let color = &mesh.attributes[0];
        assert_eq!(color.channels, 3);
        assert_eq!(
            color.values,
            [255.0, 128.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0]
        );
        let close = |got: &[f32], want: &[f32]| {
            got.len() == want.len() && got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-5)
        };
        let w = &mesh.attributes[1].values;
        assert!(close(w, &[0.217703, -0.039004, 1.0]), "{w:?}");
        let q = &mesh.attributes[2].values;
        assert!(close(q, &[0.214048, 0.010022, 1.0]), "{q:?}");
        // The quad's face colour repeats for both of its triangles.
        let face = &mesh.attributes[3];
        assert_eq!(mesh.indices.len(), 3);
        assert!(close(
            &face.values,
            &[0.5, 2.0, -1.0, 0.1, 0.2, 0.3, 0.1, 0.2, 0.3]
        ));
        assert!(face.per_face() && !color.per_face());
    }

    #[test]
    fn positions_only_has_no_normals_or_uvs() {
        let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
                   property double z\nelement face 1\nproperty list uchar uint vertex_index\nend_header\n\
                   0 0 0\n1 0 0\n0 1 0\n3 2 1 0\n";
        let mesh = load_bytes(ply.as_bytes()).unwrap();
        assert_eq!(mesh.indices, vec![[2, 1, 0]]);
        assert!(mesh.normals.is_none() && mesh.uvs.is_none());
    }

    /// A binary PLY: a pentagon with `texture_u`/`texture_v`, an extra
    /// element before the faces, and ushort indices.
    fn binary_pentagon(big_endian: bool) -> Vec<u8> {
        let format = if big_endian {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        };
        let header = format!(
            "ply\nformat {format} 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
             property float z\nproperty float texture_u\nproperty float texture_v\n\
             element material 1\nproperty uchar id\n\
             element face 1\nproperty list int ushort vertex_indices\nend_header\n"
        );
        let mut out = header.into_bytes();
        let f32_bytes = |v: f32| {
            if big_endian {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        for i in 0..5 {
            let angle = i as f32 * std::f32::consts::TAU / 5.0;
            for v in [angle.cos(), angle.sin(), 0.0, i as f32, 0.5] {
                out.extend(f32_bytes(v));
            }
        }
        out.push(7); // the material row
        out.extend(if big_endian {
            5i32.to_be_bytes()
        } else {
            5i32.to_le_bytes()
        });
        for i in 0..5u16 {
            out.extend(if big_endian {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
        out
    }

    #[test]
    fn binary_pentagon_is_fan_triangulated_in_both_byte_orders() {
        for big_endian in [false, true] {
            let mesh = load_bytes(&binary_pentagon(big_endian)).unwrap();
            assert_eq!(mesh.positions.len(), 5);
            assert_eq!(mesh.positions[0], Vec3::new(1.0, 0.0, 0.0));
            assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
            assert_eq!(mesh.uvs.unwrap()[4], Vec2::new(4.0, 0.5));
        }
    }

    #[test]
    fn truncated_binary_file_is_an_error() {
        let full = binary_pentagon(false);
        let header_len = full.len() - (5 * 20 + 1 + 4 + 10);
        for cut in [header_len + 7, header_len + 100, full.len() - 1] {
            let err = load_bytes(&full[..cut]).unwrap_err().to_string();
            assert!(err.contains("truncated"), "cut at {cut}: {err}");
        }
    }

    #[test]
    fn truncated_ascii_file_names_the_line() {
        let cut = ASCII_QUAD.find("1 1 0 0").unwrap();
        let err = load_bytes(&ASCII_QUAD.as_bytes()[..cut])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(":20: file is truncated: it ends in vertex 2 of 4"),
            "{err}"
        );
    }

    #[test]
    fn index_out_of_range_is_an_error() {
        let ply = ASCII_QUAD.replace("4 0 1 2 3 7", "4 0 1 2 9 7");
        let err = load_bytes(ply.as_bytes()).unwrap_err().to_string();
        assert!(
            err.contains(":22: face 0: vertex index 9 out of range (the file has 4 vertices)"),
            "{err}"
        );
        let ply = ASCII_QUAD
            .replace("property list uchar int", "property list uchar char")
            .replace("4 0 1 2 3 7", "3 0 -1 2 7");
        let err = load_bytes(ply.as_bytes()).unwrap_err().to_string();
        assert!(err.contains("vertex index -1 out of range"), "{err}");
    }

    #[test]
    fn missing_coordinates_and_faces_are_errors() {
        let no_z = ASCII_QUAD.replace("property float z\n", "");
        let err = load_bytes(no_z.as_bytes()).unwrap_err().to_string();
        assert!(err.contains("no scalar 'z' property"), "{err}");
        let points =
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                      property float z\nend_header\n0 0 0\n";
        let err = load_bytes(points.as_bytes()).unwrap_err().to_string();
        assert!(err.contains("no 'face' element"), "{err}");
    }

    #[test]
    fn malformed_files_are_errors_not_panics() {
        let cases: [&[u8]; 7] = [
            b"",
            b"not a ply file\n",
            b"ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\nend_header\n",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n",
            b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n\
              property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\x00",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
              element face 1\nproperty list uchar int vertex_indices\nend_header\n0 zero 0\n3 0 0 0\n",
            b"ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n\
              element face 1\nproperty list int int vertex_indices\nend_header\n\xff\xff\xff\xff",
        ];
        for bytes in cases {
            assert!(
                load_bytes(bytes).is_err(),
                "{:?}",
                String::from_utf8_lossy(bytes)
            );
        }
        let err = load_bytes(cases[5]).unwrap_err().to_string();
        assert!(err.contains(":10: vertex 0 of 1"), "{err}");
        let err = load_bytes(cases[2]).unwrap_err().to_string();
        assert!(err.contains(":3: number too large"), "{err}");
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let err = load_ply(Path::new("/nonexistent/yubin-missing.ply")).unwrap_err();
        assert!(matches!(err, SceneError::Io { .. }));
        assert!(err.to_string().contains("yubin-missing.ply"));
    }

    #[test]
    fn shared_mitsuba_ply_files_load() {
        let dir = crate::shared_path("mitsuba-data/tests/ply");
        let Ok(entries) = std::fs::read_dir(&dir) else {
            println!("skipped: {} not found", dir.display());
            return;
        };
        let mut loaded = 0;
        for entry in entries.flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "ply") {
                let mesh = load_ply(&path).unwrap_or_else(|e| panic!("{e}"));
                assert!(!mesh.indices.is_empty(), "{}", path.display());
                loaded += 1;
            }
        }
        assert!(loaded >= 6, "only {loaded} PLY files found");
        let rect = load_ply(&dir.join("rectangle_normals_uv.ply")).unwrap();
        assert_eq!((rect.positions.len(), rect.indices.len()), (4, 2));
        assert_eq!(rect.uvs.unwrap()[0], Vec2::new(0.950589, 0.988416));
        let colors = load_ply(&dir.join("triangle_face_colors.ply")).unwrap();
        assert_eq!(colors.indices, vec![[0, 1, 2]]);
        assert!(colors.normals.is_some());
    }

    #[test]
    fn shared_bunny_loads_with_the_right_counts() {
        let path = crate::shared_path("mitsuba-data/common/meshes/bunny.ply");
        if !path.exists() {
            println!("skipped: {} not found", path.display());
            return;
        }
        let start = std::time::Instant::now();
        let mesh = load_ply(&path).unwrap();
        println!("bunny.ply loaded in {:?}", start.elapsed());
        assert_eq!(mesh.positions.len(), 35947);
        assert_eq!(mesh.indices.len(), 69451);
        assert!(mesh.normals.is_none());
    }
}
