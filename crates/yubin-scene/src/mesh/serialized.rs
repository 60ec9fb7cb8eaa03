//! Mitsuba's binary `serialized` mesh files.
//!
//! [`load_serialized`] reads one mesh of a `.serialized` file (the
//! "binary mesh format" of Mitsuba 0.x and 3) into a [`MeshData`].
//!
//! # Layout
//!
//! A file is a sequence of meshes followed by a table of where each starts.
//! All numbers are little-endian.
//!
//! | part | contents |
//! |---|---|
//! | mesh header | `u16` format identifier `0x041C`, `u16` version (3 or 4) |
//! | mesh body | one zlib stream, below |
//! | … | more meshes, each a header and a body |
//! | offset table | one entry per mesh: its byte offset from the start of the file, `u64` (version 4) or `u32` (version 3) |
//! | mesh count | `u32` |
//!
//! The zlib stream of a mesh holds, in order:
//!
//! | field | type | notes |
//! |---|---|---|
//! | flags | `u32` | `0x0001` vertex normals, `0x0002` texture coordinates, `0x0008` vertex colours, `0x0010` face-normals hint, `0x2000` double precision (else single; `0x1000` says single explicitly) |
//! | name | UTF-8, NUL-terminated | version 4 only |
//! | vertex count, triangle count | `u64`, `u64` | |
//! | positions | 3 reals per vertex | `f32`, or `f64` with `0x2000` |
//! | normals | 3 reals per vertex | with `0x0001` |
//! | texture coordinates | 2 reals per vertex | with `0x0002` |
//! | colours | 3 reals per vertex | with `0x0008`; the attribute `vertex_color` |
//! | triangles | 3 indices each | `u32` (`u64` when there are more than 2³² vertices, which yubin rejects) |
//!
//! Like Mitsuba 3, the loader keeps texture coordinates as stored (no `v`
//! flip, unlike `obj`) and ignores the face-normals hint of the file:
//! flat shading comes only from the shape's `face_normals` parameter.
//! Unknown flags are ignored.
//!
//! In a Mitsuba scene:
//!
//! ```xml
//! <shape type="serialized">
//!     <string name="filename" value="meshes/matpreview.serialized"/>
//!     <integer name="shape_index" value="2"/>
//! </shape>
//! ```
//!
//! # Errors
//!
//! A missing or unreadable file is [`SceneError::Io`]. Everything else
//! names the file and says what is wrong: a file too short to hold a mesh
//! table, a bad identifier or version, a `shape_index` beyond the mesh
//! count (with the count), a corrupt or truncated zlib stream, a triangle
//! index out of range.

use std::io::{self, Read};
use std::path::Path;

use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3};

use super::MeshData;
use crate::error::SceneError;
use yubin_core::texture::NamedAttribute;

/// The `u16` at the start of every mesh.
const FORMAT_ID: u16 = 0x041C;
/// Per-vertex normals follow the positions.
const HAS_NORMALS: u32 = 0x0001;
/// Per-vertex texture coordinates follow.
const HAS_UVS: u32 = 0x0002;
/// Per-vertex colours follow.
const HAS_COLORS: u32 = 0x0008;
/// Reals are `f64` rather than `f32`.
const DOUBLE_PRECISION: u32 = 0x2000;

/// Loads mesh number `shape_index` (from 0) of the serialized file at
/// `path`. See the module docs.
pub fn load_serialized(path: &Path, shape_index: usize) -> Result<MeshData, SceneError> {
    let bytes = std::fs::read(path).map_err(|error| SceneError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse(&bytes, shape_index).map_err(|msg| SceneError::file(path, msg))
}

/// Parses a whole file held in memory; errors are messages without the
/// file name.
fn parse(bytes: &[u8], shape_index: usize) -> Result<MeshData, String> {
    // The first mesh's version decides the width of the offset table.
    let (_, first_version) = mesh_header(bytes, 0)?;
    let entry_size: usize = if first_version == 3 { 4 } else { 8 };
    let too_short = || {
        format!(
            "not a serialized mesh file: {} bytes cannot hold a mesh and the table of mesh offsets",
            bytes.len()
        )
    };
    let count_at = bytes.len().checked_sub(4).ok_or_else(too_short)?;
    let count = read_u32(bytes, count_at) as usize;
    if count == 0 {
        return Err("the file's mesh table says it holds no meshes".into());
    }
    let table_at = count
        .checked_mul(entry_size)
        .and_then(|table_size| count_at.checked_sub(table_size))
        .filter(|&at| at >= 4)
        .ok_or_else(|| {
            format!(
                "the file's mesh table claims {count} meshes, more than its {} bytes can hold",
                bytes.len()
            )
        })?;
    if shape_index >= count {
        let meshes = if count == 1 {
            "1 mesh (shape_index 0)".to_string()
        } else {
            format!("{count} meshes (shape_index 0 to {})", count - 1)
        };
        return Err(format!(
            "shape_index {shape_index} is out of range: the file holds {meshes}"
        ));
    }
    let entry_at = table_at + shape_index * entry_size;
    let offset = if entry_size == 4 {
        u64::from(read_u32(bytes, entry_at))
    } else {
        read_u64(bytes, entry_at)
    };
    let offset = usize::try_from(offset)
        .ok()
        .filter(|&o| o.checked_add(4).is_some_and(|end| end <= table_at))
        .ok_or_else(|| {
            format!(
                "mesh {shape_index} starts at byte {offset}, past the end of the mesh data ({table_at} bytes)"
            )
        })?;
    let (body_start, version) = mesh_header(&bytes[..table_at], offset)
        .map_err(|msg| format!("mesh {shape_index} (at byte {offset}): {msg}"))?;
    let mut body = MeshBody {
        stream: ZlibDecoder::new(&bytes[body_start..table_at]),
        mesh: shape_index,
    };
    read_mesh(&mut body, version)
}

/// Checks the identifier and version at `at`; returns where the zlib stream
/// begins and the version.
fn mesh_header(bytes: &[u8], at: usize) -> Result<(usize, u16), String> {
    if bytes.len() < at + 4 {
        return Err(format!(
            "not a serialized mesh file: {} bytes is too short for a mesh header",
            bytes.len()
        ));
    }
    let id = u16::from_le_bytes([bytes[at], bytes[at + 1]]);
    let version = u16::from_le_bytes([bytes[at + 2], bytes[at + 3]]);
    if id != FORMAT_ID {
        return Err(format!(
            "not a serialized mesh file: the format identifier is {id:#06x}, not {FORMAT_ID:#06x}"
        ));
    }
    if version != 3 && version != 4 {
        return Err(format!(
            "serialized mesh format version {version} is not supported (only 3 and 4)"
        ));
    }
    Ok((at + 4, version))
}

fn read_u32(bytes: &[u8], at: usize) -> u32 {
    let mut b = [0; 4];
    b.copy_from_slice(&bytes[at..at + 4]);
    u32::from_le_bytes(b)
}

fn read_u64(bytes: &[u8], at: usize) -> u64 {
    let mut b = [0; 8];
    b.copy_from_slice(&bytes[at..at + 8]);
    u64::from_le_bytes(b)
}

/// The decompressed stream of one mesh, with errors that say which mesh.
struct MeshBody<'a> {
    stream: ZlibDecoder<&'a [u8]>,
    mesh: usize,
}

impl MeshBody<'_> {
    /// Fills `buf`, or says that `what` is cut short or corrupt.
    fn read_exact(&mut self, buf: &mut [u8], what: &str) -> Result<(), String> {
        self.stream
            .read_exact(buf)
            .map_err(|e| self.stream_error(&e, what))
    }

    fn read_u32(&mut self, what: &str) -> Result<u32, String> {
        let mut b = [0; 4];
        self.read_exact(&mut b, what)?;
        Ok(u32::from_le_bytes(b))
    }

    fn read_u64(&mut self, what: &str) -> Result<u64, String> {
        let mut b = [0; 8];
        self.read_exact(&mut b, what)?;
        Ok(u64::from_le_bytes(b))
    }

    /// Reads exactly `len` bytes. The buffer grows with the data actually
    /// decompressed, so absurd counts in a damaged file fail as truncation
    /// instead of allocating up front.
    fn read_vec(&mut self, len: usize, what: &str) -> Result<Vec<u8>, String> {
        let mut out = Vec::new();
        (&mut self.stream)
            .take(len as u64)
            .read_to_end(&mut out)
            .map_err(|e| self.stream_error(&e, what))?;
        if out.len() < len {
            return Err(format!(
                "mesh {}: truncated: the {what} end after {} of {len} bytes",
                self.mesh,
                out.len()
            ));
        }
        Ok(out)
    }

    fn stream_error(&self, e: &io::Error, what: &str) -> String {
        if e.kind() == io::ErrorKind::UnexpectedEof {
            format!("mesh {}: truncated while reading the {what}", self.mesh)
        } else {
            format!(
                "mesh {}: corrupt compressed data while reading the {what}: {e}",
                self.mesh
            )
        }
    }
}

/// Reads the fields of one mesh's zlib stream.
fn read_mesh(body: &mut MeshBody, version: u16) -> Result<MeshData, String> {
    let mesh = body.mesh;
    let flags = body.read_u32("flags")?;
    if version >= 4 {
        // The mesh name: NUL-terminated; not used.
        loop {
            let mut b = [0];
            body.read_exact(&mut b, "mesh name")?;
            if b[0] == 0 {
                break;
            }
        }
    }
    let vertex_count = body.read_u64("vertex count")?;
    let triangle_count = body.read_u64("triangle count")?;
    if vertex_count > u64::from(u32::MAX) {
        return Err(format!(
            "mesh {mesh}: {vertex_count} vertices need 64-bit indices, which are not supported"
        ));
    }
    // Fits: checked against u32::MAX above.
    let n = vertex_count as usize;
    let real = if flags & DOUBLE_PRECISION != 0 { 8 } else { 4 };
    let size = |reals_per_vertex: usize| {
        n.checked_mul(reals_per_vertex * real)
            .ok_or_else(|| format!("mesh {mesh}: {vertex_count} vertices is too many"))
    };
    let positions = read_vec3s(body, size(3)?, real, "vertex positions")?;
    let normals = if flags & HAS_NORMALS != 0 {
        Some(read_vec3s(body, size(3)?, real, "vertex normals")?)
    } else {
        None
    };
    let uvs = if flags & HAS_UVS != 0 {
        let reals = read_reals(body, size(2)?, real, "texture coordinates")?;
        Some(
            reals
                .chunks_exact(2)
                .map(|c| Vec2::new(c[0], c[1]))
                .collect(),
        )
    } else {
        None
    };
    let mut attributes = Vec::new();
    if flags & HAS_COLORS != 0 {
        // Mitsuba 3 names them `vertex_color`, for `mesh_attribute`.
        attributes.push(NamedAttribute {
            name: "vertex_color".into(),
            channels: 3,
            values: read_reals(body, size(3)?, real, "vertex colours")?,
        });
    }
    let index_bytes = usize::try_from(triangle_count)
        .ok()
        .and_then(|t| t.checked_mul(12))
        .ok_or_else(|| format!("mesh {mesh}: {triangle_count} triangles is too many"))?;
    let raw = body.read_vec(index_bytes, "triangle indices")?;
    let mut indices = Vec::with_capacity(raw.len() / 12);
    for (t, tri) in raw.chunks_exact(12).enumerate() {
        let mut face = [0; 3];
        for (k, v) in face.iter_mut().enumerate() {
            let i =
                u32::from_le_bytes([tri[4 * k], tri[4 * k + 1], tri[4 * k + 2], tri[4 * k + 3]]);
            if u64::from(i) >= vertex_count {
                return Err(format!(
                    "mesh {mesh}: triangle {t} uses vertex {i}, but the mesh has {vertex_count} vertices"
                ));
            }
            *v = i;
        }
        indices.push(face);
    }
    Ok(MeshData {
        positions,
        normals,
        uvs,
        indices,
        attributes,
    })
}

/// Reads `len` bytes of reals of `real` bytes each, as `f32`.
fn read_reals(
    body: &mut MeshBody,
    len: usize,
    real: usize,
    what: &str,
) -> Result<Vec<f32>, String> {
    let raw = body.read_vec(len, what)?;
    Ok(if real == 8 {
        raw.chunks_exact(8)
            .map(|c| {
                let mut b = [0; 8];
                b.copy_from_slice(c);
                f64::from_le_bytes(b) as f32
            })
            .collect()
    } else {
        raw.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    })
}

fn read_vec3s(
    body: &mut MeshBody,
    len: usize,
    real: usize,
    what: &str,
) -> Result<Vec<Vec3>, String> {
    let reals = read_reals(body, len, real, what)?;
    Ok(reals
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use flate2::write::ZlibEncoder;
    use flate2::Compression;
    use std::io::Write;
    use std::path::PathBuf;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// One mesh to encode.
    struct TestMesh {
        version: u16,
        flags: u32,
        positions: Vec<f64>,
        normals: Vec<f64>,
        uvs: Vec<f64>,
        colors: Vec<f64>,
        indices: Vec<u32>,
    }

    /// A quad in the z = 0 plane with normals and uvs.
    fn quad(version: u16, flags: u32) -> TestMesh {
        TestMesh {
            version,
            flags,
            positions: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
            normals: [0.0, 0.0, 1.0].repeat(4),
            uvs: vec![0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.25, 0.75],
            colors: [0.5, 0.25, 0.125].repeat(4),
            indices: vec![0, 1, 2, 0, 2, 3],
        }
    }

    /// Writes `meshes` in the serialized format (our own encoder, written
    /// from the format description in the module docs).
    fn encode(meshes: &[TestMesh]) -> Vec<u8> {
        let mut file = Vec::new();
        let mut offsets = Vec::new();
        for m in meshes {
            offsets.push(file.len() as u64);
            file.extend_from_slice(&FORMAT_ID.to_le_bytes());
            file.extend_from_slice(&m.version.to_le_bytes());
            let mut body = Vec::new();
            body.extend_from_slice(&m.flags.to_le_bytes());
            if m.version == 4 {
                body.extend_from_slice(b"test mesh\0");
            }
            body.extend_from_slice(&(m.positions.len() as u64 / 3).to_le_bytes());
            body.extend_from_slice(&(m.indices.len() as u64 / 3).to_le_bytes());
            let mut reals = |values: &[f64], flag: u32| {
                if flag != 0 && m.flags & flag == 0 {
                    return;
                }
                for &v in values {
                    if m.flags & DOUBLE_PRECISION != 0 {
                        body.extend_from_slice(&v.to_le_bytes());
                    } else {
                        body.extend_from_slice(&(v as f32).to_le_bytes());
                    }
                }
            };
            reals(&m.positions, 0);
            reals(&m.normals, HAS_NORMALS);
            reals(&m.uvs, HAS_UVS);
            reals(&m.colors, HAS_COLORS);
            for i in &m.indices {
                body.extend_from_slice(&i.to_le_bytes());
            }
            let mut z = ZlibEncoder::new(Vec::new(), Compression::default());
            z.write_all(&body).unwrap();
            file.extend_from_slice(&z.finish().unwrap());
        }
        for (o, m) in offsets.iter().zip(meshes) {
            if m.version == 3 {
                file.extend_from_slice(&(*o as u32).to_le_bytes());
            } else {
                file.extend_from_slice(&o.to_le_bytes());
            }
        }
        file.extend_from_slice(&(meshes.len() as u32).to_le_bytes());
        file
    }

    /// A fresh path in the temp directory.
    fn temp_path() -> PathBuf {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        std::env::temp_dir().join(format!(
            "yubin-serialized-test-{}-{n}.serialized",
            std::process::id()
        ))
    }

    #[test]
    fn a_written_file_reads_back() {
        let mut second = quad(4, DOUBLE_PRECISION | HAS_UVS | HAS_COLORS);
        second.positions[11] = 2.5;
        let bytes = encode(&[quad(4, 0x1000 | HAS_NORMALS | HAS_UVS), second]);
        let path = temp_path();
        std::fs::write(&path, &bytes).unwrap();
        let first = load_serialized(&path, 0);
        let second = load_serialized(&path, 1);
        let beyond = load_serialized(&path, 2);
        let _ = std::fs::remove_file(&path);

        let first = first.unwrap();
        assert_eq!(first.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(first.normals, Some(vec![Vec3::Z; 4]));
        // Stored as is: no v flip.
        assert_eq!(first.uvs.as_ref().unwrap()[3], Vec2::new(0.25, 0.75));
        assert_eq!(first.indices, vec![[0, 1, 2], [0, 2, 3]]);

        let second = second.unwrap();
        assert_eq!(second.positions[3], Vec3::new(0.0, 1.0, 2.5));
        assert_eq!(second.normals, None);
        assert_eq!(second.uvs.unwrap()[1], Vec2::new(1.0, 0.0));
        assert_eq!(second.indices, first.indices);
        assert!(first.attributes.is_empty());
        let colors = &second.attributes[0];
        assert_eq!((colors.name.as_str(), colors.channels), ("vertex_color", 3));
        assert_eq!(colors.values[9..], [0.5, 0.25, 0.125]);

        let msg = beyond.unwrap_err().to_string();
        assert!(msg.contains(&*path.to_string_lossy()), "{msg}");
        assert!(
            msg.contains("shape_index 2 is out of range: the file holds 2 meshes"),
            "{msg}"
        );
    }

    #[test]
    fn version_3_has_no_name_and_a_u32_offset_table() {
        let bytes = encode(&[quad(3, HAS_NORMALS), quad(3, 0), quad(3, HAS_UVS)]);
        let mesh = parse(&bytes, 2).unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert!(mesh.normals.is_none());
        assert_eq!(mesh.uvs.unwrap()[2], Vec2::ONE);
        assert!(parse(&bytes, 1).unwrap().uvs.is_none());
    }

    #[test]
    fn bad_files_are_errors_that_say_why() {
        let good = encode(&[quad(4, HAS_NORMALS | HAS_UVS)]);
        let err = |bytes: &[u8]| parse(bytes, 0).unwrap_err();

        assert!(err(&[]).contains("too short"));
        let mut magic = good.clone();
        magic[0] = 0x1d;
        assert!(err(&magic).contains("format identifier is 0x041d"));
        let mut version = good.clone();
        version[2] = 5;
        assert!(err(&version).contains("version 5 is not supported"));
        let mut count = good.clone();
        let n = count.len();
        count[n - 4] = 0;
        assert!(err(&count).contains("holds no meshes"));
        count[n - 4] = 200;
        assert!(err(&count).contains("claims 200 meshes"));
        let mut offset = good.clone();
        offset[n - 12] = 100;
        assert!(err(&offset).contains("past the end"));

        // Cut off inside the zlib stream, table kept intact.
        let table = good[good.len() - 12..].to_vec();
        let mut cut = good[..good.len() - 40].to_vec();
        cut.extend_from_slice(&table);
        let msg = err(&cut);
        assert!(msg.contains("truncated"), "{msg}");

        // A triangle index out of range.
        let mut m = quad(4, 0);
        m.indices[4] = 9;
        let msg = err(&encode(&[m]));
        assert!(
            msg.contains("triangle 1 uses vertex 9, but the mesh has 4 vertices"),
            "{msg}"
        );

        // Garbage inside the compressed stream.
        let mut garbage = good.clone();
        for b in &mut garbage[6..20] {
            *b ^= 0x5a;
        }
        let msg = err(&garbage);
        assert!(msg.contains("mesh 0"), "{msg}");
    }

    #[test]
    fn no_input_panics() {
        // Every prefix of a valid file (with and without its table), and
        // bytes flipped one at a time: errors or meshes, never a panic.
        let good = encode(&[quad(4, HAS_NORMALS | HAS_UVS | HAS_COLORS), quad(3, 0)]);
        for len in 0..good.len() {
            let _ = parse(&good[..len], 0);
            let _ = parse(&good[..len], 1);
        }
        let mut state = 0x2545_f491_u32;
        for i in 0..good.len() {
            for _ in 0..4 {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                let mut bad = good.clone();
                bad[i] ^= (state as u8) | 1;
                let _ = parse(&bad, 0);
                let _ = parse(&bad, 1);
            }
        }
        // A mesh claiming billions of vertices in a tiny stream.
        let mut huge = quad(4, 0);
        huge.positions.truncate(3);
        let mut bytes = encode(&[huge]);
        let body_start = 4;
        let mut body = Vec::new();
        ZlibDecoder::new(&bytes[body_start..bytes.len() - 12])
            .read_to_end(&mut body)
            .unwrap();
        let counts = 4 + b"test mesh\0".len();
        body[counts..counts + 8].copy_from_slice(&(u64::from(u32::MAX)).to_le_bytes());
        let mut z = ZlibEncoder::new(Vec::new(), Compression::default());
        z.write_all(&body).unwrap();
        let table = bytes[bytes.len() - 12..].to_vec();
        bytes.truncate(body_start);
        bytes.extend_from_slice(&z.finish().unwrap());
        bytes.extend_from_slice(&table);
        let msg = parse(&bytes, 0).unwrap_err();
        assert!(msg.contains("truncated"), "{msg}");
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let err = load_serialized(Path::new("/nonexistent/yubin-missing.serialized"), 0);
        let err = err.unwrap_err();
        assert!(matches!(err, SceneError::Io { .. }));
        assert!(err.to_string().contains("yubin-missing.serialized"));
    }

    /// Values checked against Mitsuba 3.9.1 (`mi.traverse` of the loaded
    /// shape): counts, first values, and texture coordinates as stored.
    #[test]
    fn mitsuba_serialized_files_load_shared() {
        let dir = crate::shared_path("mitsuba-data");
        let tests = dir.join("tests/serialized");
        if !tests.is_dir() {
            println!("skipped: {} not found", tests.display());
            return;
        }
        let rect = load_serialized(&tests.join("rectangle_normals_uv.serialized"), 0).unwrap();
        assert_eq!(rect.positions.len(), 4);
        assert_eq!(rect.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(rect.positions[0], Vec3::new(-2.85, 0.0, -7.6));
        assert_eq!(rect.normals, Some(vec![Vec3::Y; 4]));
        // Mitsuba keeps v as stored (the PLY twin of this file has 0.988416).
        assert_eq!(rect.uvs.unwrap()[0], Vec2::new(0.950589, 0.011583984));
        let normals = load_serialized(&tests.join("rectangle_normals.serialized"), 0).unwrap();
        assert!(normals.uvs.is_none() && normals.normals.is_some());
        let uv = load_serialized(&tests.join("rectangle_uv.serialized"), 0).unwrap();
        assert!(uv.uvs.is_some() && uv.normals.is_none());

        let matpreview = dir.join("scenes/matpreview/matpreview.serialized");
        let counts: Vec<_> = (0..3)
            .map(|i| {
                let m = load_serialized(&matpreview, i).unwrap();
                assert!(m.normals.is_some() && m.uvs.is_some());
                (m.positions.len(), m.indices.len())
            })
            .collect();
        assert_eq!(counts, [(289, 512), (2078, 3936), (29439, 57152)]);
        let plane = load_serialized(&matpreview, 0).unwrap();
        assert_eq!(plane.indices[..2], [[0, 1, 2], [1, 0, 3]]);
        assert_eq!(
            plane.positions[0],
            Vec3::new(-0.50486624, 0.57472086, 0.784379)
        );
        assert_eq!(plane.uvs.unwrap()[0], Vec2::new(0.644658, 0.80923563));
        let msg = load_serialized(&matpreview, 3).unwrap_err().to_string();
        assert!(
            msg.contains("matpreview.serialized: shape_index 3 is out of range: the file holds 3 meshes (shape_index 0 to 2)"),
            "{msg}"
        );
    }
}
