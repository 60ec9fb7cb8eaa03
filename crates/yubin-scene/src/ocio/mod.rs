//! OpenColorIO configs: yubin applies a config's display views and looks
//! to its renders (`yubin render --ocio CONFIG --view Filmic --look
//! "High Contrast"`, or `$OCIO`), with its own reader and processor for the
//! transforms Blender's configs use, so that no C++ library is needed.
//!
//! A processor takes the config's `scene_linear` space (yubin's linear
//! Rec.709) through each look (to its `process_space`, then its transform)
//! and then to the view's colour space, each colour space change going
//! through the reference space (`to_reference`, or the inverse of
//! `from_reference`), as OpenColorIO builds it.
//!
//! Transforms: `GroupTransform`, `ColorSpaceTransform`, `FileTransform`
//! (`.spi1d`, `.spi3d`, `.spimtx`, `.cube`; linear, trilinear and
//! tetrahedral interpolation, inverse 1D LUTs), `MatrixTransform`,
//! `AllocationTransform` (`uniform`, `lg2`), `LogTransform`,
//! `LogAffineTransform`, `ExponentTransform`,
//! `ExponentWithLinearTransform`, `RangeTransform`, `CDLTransform`, each
//! with `direction: inverse` where it has an inverse. Another transform in
//! the path of the chosen view is an error naming it and its line.
//! Colour spaces are found by name, alias or role, ignoring case.

mod lut_files;
mod ops;
mod yaml;

use ops::Op;

use crate::error::{Location, SceneError};
use lut_files::{read_lut, Interpolation};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use yaml::Node;

/// Nesting beyond this is taken for a cycle of colour spaces.
const MAX_DEPTH: usize = 64;

/// A colour space: its names and its transforms to and from the reference.
#[derive(Debug)]
struct ColorSpace {
    name: String,
    aliases: Vec<String>,
    is_data: bool,
    to_reference: Option<Node>,
    from_reference: Option<Node>,
}

#[derive(Debug)]
struct View {
    name: String,
    colorspace: Option<String>,
    looks: Option<String>,
    line: u32,
}

#[derive(Debug)]
struct Display {
    name: String,
    views: Vec<View>,
}

#[derive(Debug)]
struct Look {
    name: String,
    process_space: String,
    transform: Option<Node>,
    inverse_transform: Option<Node>,
    line: u32,
}

/// An OpenColorIO config, read from its file.
#[derive(Debug)]
pub struct Config {
    file: Arc<PathBuf>,
    search_paths: Vec<PathBuf>,
    roles: Vec<(String, String)>,
    colorspaces: Vec<ColorSpace>,
    displays: Vec<Display>,
    active_displays: Vec<String>,
    active_views: Vec<String>,
    looks: Vec<Look>,
    luts: Mutex<HashMap<(PathBuf, Interpolation), Vec<Op>>>,
}

/// A display view's chain of operations, ready to apply to pixels.
#[derive(Clone, Debug)]
pub struct Processor {
    ops: Vec<Op>,
    /// "display / view (looks)", for messages.
    pub description: String,
}

impl Processor {
    /// The display value of a scene-linear RGB value.
    pub fn apply(&self, rgb: [f32; 3]) -> [f32; 3] {
        self.ops.iter().fold(rgb, |v, op| op.apply(v))
    }
}

fn strings(node: Option<&Node>) -> Vec<String> {
    node.map(|n| {
        n.items()
            .iter()
            .filter_map(|i| i.text().map(str::to_string))
            .collect()
    })
    .unwrap_or_default()
}

fn text(node: &Node, key: &str) -> Option<String> {
    node.get(key).and_then(Node::text).map(str::to_string)
}

/// A transform node that is more than an empty group.
fn transform(node: &Node, key: &str) -> Option<Node> {
    node.get(key).filter(|n| n.tag.is_some()).cloned()
}

impl Config {
    /// Reads the config at `path` (LUTs are read when a processor needs them).
    pub fn load(path: &Path) -> Result<Config, SceneError> {
        let source = std::fs::read_to_string(path).map_err(|error| SceneError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        let file = Arc::new(path.to_path_buf());
        let root = yaml::parse(&source, &file)?;
        let at = |line: u32, msg: String| SceneError::at(&Location::new(file.clone(), line), msg);
        if root.get("ocio_profile_version").is_none() {
            return Err(at(
                1,
                "not an OpenColorIO config (no ocio_profile_version)".into(),
            ));
        }
        let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let search_paths = match root.get("search_path") {
            Some(n) if !n.items().is_empty() => strings(Some(n)),
            Some(n) => n
                .text()
                .map(|t| t.split(':').map(str::to_string).collect())
                .unwrap_or_default(),
            None => Vec::new(),
        }
        .into_iter()
        .map(|p| dir.join(p))
        .chain(std::iter::once(dir.clone()))
        .collect();
        let roles = root
            .get("roles")
            .map(|r| {
                r.entries()
                    .iter()
                    .filter_map(|(k, v)| Some((k.clone(), v.text()?.to_string())))
                    .collect()
            })
            .unwrap_or_default();
        let mut colorspaces = Vec::new();
        for cs in root.get("colorspaces").map(Node::items).unwrap_or_default() {
            let name = text(cs, "name")
                .ok_or_else(|| at(cs.line, "colour space without a name".into()))?;
            // `to_scene_reference` is OCIO v2's name for `to_reference`;
            // the last one written wins.
            let pick = |a: &str, b: &str| {
                cs.entries()
                    .iter()
                    .rev()
                    .find(|(k, _)| k == a || k == b)
                    .and_then(|(_, n)| (n.tag.is_some()).then(|| n.clone()))
            };
            colorspaces.push(ColorSpace {
                name,
                aliases: strings(cs.get("aliases")),
                is_data: text(cs, "isdata").is_some_and(|v| v == "true"),
                to_reference: pick("to_reference", "to_scene_reference"),
                from_reference: pick("from_reference", "from_scene_reference"),
            });
        }
        let mut displays = Vec::new();
        for (name, views) in root.get("displays").map(Node::entries).unwrap_or_default() {
            let views = views
                .items()
                .iter()
                .map(|v| {
                    if let Some(vt) = v.get("view_transform") {
                        return Err(at(
                            vt.line,
                            "views with a view_transform (display-referred colour spaces) are not supported".into(),
                        ));
                    }
                    Ok(View {
                        name: text(v, "name").unwrap_or_default(),
                        colorspace: text(v, "colorspace"),
                        looks: text(v, "looks"),
                        line: v.line,
                    })
                })
                .collect::<Result<_, _>>();
            displays.push(Display {
                name: name.clone(),
                views: views?,
            });
        }
        let looks = root
            .get("looks")
            .map(Node::items)
            .unwrap_or_default()
            .iter()
            .map(|l| Look {
                name: text(l, "name").unwrap_or_default(),
                process_space: text(l, "process_space").unwrap_or_default(),
                transform: transform(l, "transform"),
                inverse_transform: transform(l, "inverse_transform"),
                line: l.line,
            })
            .collect();
        Ok(Config {
            file,
            search_paths,
            roles,
            colorspaces,
            displays,
            active_displays: strings(root.get("active_displays")),
            active_views: strings(root.get("active_views")),
            looks,
            luts: Mutex::new(HashMap::new()),
        })
    }

    /// The config's file.
    pub fn file(&self) -> &Path {
        &self.file
    }

    fn at(&self, line: u32, msg: impl Into<String>) -> SceneError {
        SceneError::at(&Location::new(self.file.clone(), line), msg)
    }

    /// Displays in the config's order of preference (active ones first).
    pub fn display_names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = self
            .active_displays
            .iter()
            .filter(|a| self.displays.iter().any(|d| &d.name == *a))
            .map(String::as_str)
            .collect();
        if names.is_empty() {
            names = self.displays.iter().map(|d| d.name.as_str()).collect();
        }
        names
    }

    /// The views of `display` (active ones, in the display's order).
    pub fn view_names(&self, display: &str) -> Vec<&str> {
        let Some(d) = self
            .displays
            .iter()
            .find(|d| d.name.eq_ignore_ascii_case(display))
        else {
            return Vec::new();
        };
        let active = |v: &&View| {
            self.active_views.is_empty() || self.active_views.iter().any(|a| a == &v.name)
        };
        d.views
            .iter()
            .filter(active)
            .map(|v| v.name.as_str())
            .collect()
    }

    /// Every look's name.
    pub fn look_names(&self) -> Vec<&str> {
        self.looks.iter().map(|l| l.name.as_str()).collect()
    }

    fn colorspace(&self, name: &str) -> Option<&ColorSpace> {
        let find = |n: &str| {
            self.colorspaces.iter().find(|c| {
                c.name.eq_ignore_ascii_case(n)
                    || c.aliases.iter().any(|a| a.eq_ignore_ascii_case(n))
            })
        };
        find(name).or_else(|| {
            let role = self
                .roles
                .iter()
                .find(|(r, _)| r.eq_ignore_ascii_case(name))?;
            find(&role.1)
        })
    }

    /// The processor of `view` on `display` with `looks` (OCIO's look
    /// syntax: names separated by commas, each optionally prefixed by `+`
    /// or `-` for the inverse), from the config's `scene_linear` space.
    /// `None` picks the default display (the first active one), the
    /// display's first view and the view's own looks.
    pub fn display_processor(
        &self,
        display: Option<&str>,
        view: Option<&str>,
        looks: Option<&str>,
    ) -> Result<Processor, SceneError> {
        let displays = self.display_names();
        let display_name = display
            .or(displays.first().copied())
            .ok_or_else(|| self.at(0, "the config defines no displays"))?;
        let Some(display) = self
            .displays
            .iter()
            .find(|d| d.name.eq_ignore_ascii_case(display_name))
        else {
            return Err(self.at(
                0,
                format!(
                    "no display \"{display_name}\" (displays: {})",
                    displays.join(", ")
                ),
            ));
        };
        let views = self.view_names(&display.name);
        let view_name = view
            .or(views.first().copied())
            .ok_or_else(|| self.at(0, format!("display \"{}\" has no views", display.name)))?;
        let Some(view) = display
            .views
            .iter()
            .find(|v| v.name.eq_ignore_ascii_case(view_name))
        else {
            return Err(self.at(
                0,
                format!(
                    "display \"{}\" has no view \"{view_name}\" (views: {})",
                    display.name,
                    views.join(", ")
                ),
            ));
        };
        let target = view.colorspace.as_deref().ok_or_else(|| {
            self.at(
                view.line,
                format!("view \"{}\" names no colorspace", view.name),
            )
        })?;
        let looks = looks.or(view.looks.as_deref()).unwrap_or("");
        let mut ops = Vec::new();
        let mut current = "scene_linear".to_string();
        let mut applied = Vec::new();
        for token in looks
            .split([',', ':'])
            .map(str::trim)
            .filter(|t| !t.is_empty())
        {
            let (inverse, name) = match token.strip_prefix('-') {
                Some(n) => (true, n.trim()),
                None => (false, token.strip_prefix('+').unwrap_or(token).trim()),
            };
            let Some(look) = self
                .looks
                .iter()
                .find(|l| l.name.eq_ignore_ascii_case(name))
            else {
                return Err(self.at(
                    0,
                    format!(
                        "no look \"{name}\" (looks: {})",
                        self.look_names().join(", ")
                    ),
                ));
            };
            ops.extend(self.convert(&current, &look.process_space, look.line, 0)?);
            let (node, invert) = match (inverse, &look.transform, &look.inverse_transform) {
                (false, Some(t), _) => (Some(t), false),
                (false, None, Some(t)) => (Some(t), true),
                (true, _, Some(t)) => (Some(t), false),
                (true, Some(t), None) => (Some(t), true),
                (_, None, None) => (None, false),
            };
            if let Some(node) = node {
                ops.extend(self.ops_of(node, invert, 0)?);
            }
            current = look.process_space.clone();
            applied.push(token.to_string());
        }
        ops.extend(self.convert(&current, target, view.line, 0)?);
        let mut description = format!("{} / {}", display.name, view.name);
        if !applied.is_empty() {
            description += &format!(" ({})", applied.join(", "));
        }
        Ok(Processor {
            ops: ops::fuse_matrices(ops),
            description,
        })
    }

    /// Operations from colour space `src` to `dst`.
    fn convert(
        &self,
        src: &str,
        dst: &str,
        line: u32,
        depth: usize,
    ) -> Result<Vec<Op>, SceneError> {
        let find = |name: &str| {
            self.colorspace(name)
                .ok_or_else(|| self.at(line, format!("no colour space \"{name}\"")))
        };
        let (src, dst) = (find(src)?, find(dst)?);
        if std::ptr::eq(src, dst) || src.is_data || dst.is_data {
            return Ok(Vec::new());
        }
        let mut ops = match (&src.to_reference, &src.from_reference) {
            (Some(t), _) => self.ops_of(t, false, depth + 1)?,
            (None, Some(t)) => self.ops_of(t, true, depth + 1)?,
            (None, None) => Vec::new(),
        };
        ops.extend(match (&dst.from_reference, &dst.to_reference) {
            (Some(t), _) => self.ops_of(t, false, depth + 1)?,
            (None, Some(t)) => self.ops_of(t, true, depth + 1)?,
            (None, None) => Vec::new(),
        });
        Ok(ops)
    }

    fn numbers(&self, node: &Node, key: &str) -> Result<Option<Vec<f64>>, SceneError> {
        let Some(n) = node.get(key) else {
            return Ok(None);
        };
        let parse = |t: &str| {
            t.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| self.at(n.line, format!("{key}: expected a number, found \"{t}\"")))
        };
        match (n.text(), n.items()) {
            (Some(t), _) => Ok(Some(vec![parse(t)?])),
            (None, items) => items
                .iter()
                .map(|i| parse(i.text().unwrap_or("")))
                .collect::<Result<Vec<_>, _>>()
                .map(Some),
        }
    }

    /// One number per channel from a scalar or a list of 3 or 4.
    fn per_channel(&self, node: &Node, key: &str, default: f64) -> Result<[f64; 3], SceneError> {
        match self.numbers(node, key)? {
            None => Ok([default; 3]),
            Some(v) if v.len() == 1 => Ok([v[0]; 3]),
            Some(v) if v.len() == 3 || v.len() == 4 => Ok([v[0], v[1], v[2]]),
            Some(v) => Err(self.at(
                node.line,
                format!("{key}: expected 1, 3 or 4 numbers, found {}", v.len()),
            )),
        }
    }

    fn scalar(&self, node: &Node, key: &str) -> Result<Option<f64>, SceneError> {
        Ok(self.numbers(node, key)?.and_then(|v| v.first().copied()))
    }

    /// The operations of a transform node, inverted if `invert` (on top of
    /// the node's own `direction`).
    fn ops_of(&self, node: &Node, invert: bool, depth: usize) -> Result<Vec<Op>, SceneError> {
        if depth > MAX_DEPTH {
            return Err(self.at(node.line, "colour spaces refer to each other in a cycle"));
        }
        let kind = node.tag.as_deref().unwrap_or("");
        let inverse = match text(node, "direction").as_deref() {
            None | Some("forward") => invert,
            Some("inverse") => !invert,
            Some(d) => return Err(self.at(node.line, format!("{kind}: unknown direction \"{d}\""))),
        };
        let forward = match kind {
            "GroupTransform" => {
                let children = node.get("children").map(Node::items).unwrap_or_default();
                let mut ops = Vec::new();
                if inverse {
                    for c in children.iter().rev() {
                        ops.extend(self.ops_of(c, true, depth + 1)?);
                    }
                } else {
                    for c in children {
                        ops.extend(self.ops_of(c, false, depth + 1)?);
                    }
                }
                return Ok(ops);
            }
            "ColorSpaceTransform" => {
                let src = text(node, "src")
                    .ok_or_else(|| self.at(node.line, "ColorSpaceTransform without src"))?;
                let dst = text(node, "dst")
                    .ok_or_else(|| self.at(node.line, "ColorSpaceTransform without dst"))?;
                return if inverse {
                    self.convert(&dst, &src, node.line, depth + 1)
                } else {
                    self.convert(&src, &dst, node.line, depth + 1)
                };
            }
            "FileTransform" => self.file_ops(node)?,
            "MatrixTransform" => {
                let m = self.numbers(node, "matrix")?.unwrap_or_else(|| {
                    vec![
                        1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
                    ]
                });
                if m.len() != 16 {
                    return Err(self.at(
                        node.line,
                        format!(
                            "MatrixTransform: matrix needs 16 numbers, found {}",
                            m.len()
                        ),
                    ));
                }
                let offset = self.per_channel(node, "offset", 0.0)?;
                vec![Op::Matrix {
                    m: [0, 1, 2].map(|r| [m[4 * r], m[4 * r + 1], m[4 * r + 2]]),
                    offset,
                }]
            }
            "AllocationTransform" => {
                let vars = self.numbers(node, "vars")?.unwrap_or_default();
                let (min, max) = match vars.as_slice() {
                    [] => (0.0, 1.0),
                    [a, b, ..] if b > a => (*a, *b),
                    _ => {
                        return Err(self.at(
                            node.line,
                            "AllocationTransform: vars needs a minimum below a maximum",
                        ))
                    }
                };
                let fit = Op::fit([min; 3], [max; 3], [0.0; 3], [1.0; 3]);
                match text(node, "allocation").as_deref().unwrap_or("uniform") {
                    "uniform" => vec![fit],
                    "lg2" => {
                        let mut ops = Vec::new();
                        if let Some(&offset) = vars.get(2) {
                            ops.push(Op::Matrix {
                                m: IDENTITY,
                                offset: [offset; 3],
                            });
                        }
                        ops.push(Op::Log {
                            base: 2.0,
                            inverse: false,
                        });
                        ops.push(fit);
                        ops
                    }
                    a => {
                        return Err(self.at(
                            node.line,
                            format!(
                                "AllocationTransform: unknown allocation \"{a}\" (uniform, lg2)"
                            ),
                        ))
                    }
                }
            }
            "LogTransform" => vec![Op::Log {
                base: self.scalar(node, "base")?.unwrap_or(2.0),
                inverse: false,
            }],
            "LogAffineTransform" => {
                // log_slope · log_base(lin_slope · x + lin_offset) + log_offset
                let base = self.scalar(node, "base")?.unwrap_or(2.0);
                let lin = Op::fit(
                    [0.0; 3],
                    [1.0; 3],
                    self.per_channel(node, "lin_side_offset", 0.0)?,
                    sum3(
                        self.per_channel(node, "lin_side_slope", 1.0)?,
                        self.per_channel(node, "lin_side_offset", 0.0)?,
                    ),
                );
                let log = Op::fit(
                    [0.0; 3],
                    [1.0; 3],
                    self.per_channel(node, "log_side_offset", 0.0)?,
                    sum3(
                        self.per_channel(node, "log_side_slope", 1.0)?,
                        self.per_channel(node, "log_side_offset", 0.0)?,
                    ),
                );
                vec![
                    lin,
                    Op::Log {
                        base,
                        inverse: false,
                    },
                    log,
                ]
            }
            "ExponentTransform" => {
                let style = text(node, "style");
                if style.as_deref().is_some_and(|s| s != "clamp") {
                    return Err(self.at(
                        node.line,
                        format!(
                            "ExponentTransform: style \"{}\" is not supported (clamp)",
                            style.unwrap_or_default()
                        ),
                    ));
                }
                vec![Op::Pow {
                    exponent: self.per_channel(node, "value", 1.0)?,
                }]
            }
            "ExponentWithLinearTransform" => {
                let gamma = self.per_channel(node, "gamma", 1.0)?;
                let offset = self.per_channel(node, "offset", 0.0)?;
                if gamma[0] != gamma[1]
                    || gamma[1] != gamma[2]
                    || offset[0] != offset[1]
                    || offset[1] != offset[2]
                {
                    return Err(self.at(node.line, "ExponentWithLinearTransform: different values per channel are not supported"));
                }
                if gamma[0] <= 1.0 || offset[0] <= 0.0 {
                    return Err(self.at(
                        node.line,
                        "ExponentWithLinearTransform: gamma must exceed 1 and offset be positive",
                    ));
                }
                vec![Op::MonCurve {
                    gamma: gamma[0],
                    offset: offset[0],
                    encode: false,
                }]
            }
            "RangeTransform" => self.range_ops(node)?,
            "CDLTransform" => {
                let cdl = ops::Cdl {
                    slope: self.per_channel(node, "slope", 1.0)?,
                    offset: self.per_channel(node, "offset", 0.0)?,
                    power: self.per_channel(node, "power", 1.0)?,
                    saturation: self.scalar(node, "sat")?.unwrap_or(1.0),
                };
                vec![Op::Cdl {
                    cdl,
                    inverse: false,
                }]
            }
            other => {
                return Err(self.at(
                    node.line,
                    format!(
                        "{} is not supported by yubin's OCIO processor",
                        if other.is_empty() {
                            "an untagged transform"
                        } else {
                            other
                        }
                    ),
                ))
            }
        };
        if !inverse {
            return Ok(forward);
        }
        forward
            .iter()
            .rev()
            .map(|op| {
                op.inverse().ok_or_else(|| {
                    self.at(
                        node.line,
                        format!("the inverse of this {kind} is not supported"),
                    )
                })
            })
            .collect()
    }

    fn range_ops(&self, node: &Node) -> Result<Vec<Op>, SceneError> {
        let get = |k| self.scalar(node, k);
        let (min_in, max_in, min_out, max_out) = (
            get("min_in_value")?,
            get("max_in_value")?,
            get("min_out_value")?,
            get("max_out_value")?,
        );
        let clamp = text(node, "style").as_deref() != Some("noClamp");
        let mut ops = Vec::new();
        let (scale, offset) = match (min_in, max_in, min_out, max_out) {
            (Some(a), Some(b), Some(c), Some(d)) if b > a => {
                ((d - c) / (b - a), c - a * (d - c) / (b - a))
            }
            (Some(a), _, Some(c), _) => (1.0, c - a),
            (_, Some(b), _, Some(d)) => (1.0, d - b),
            (None, None, None, None) => (1.0, 0.0),
            _ => {
                return Err(self.at(
                    node.line,
                    "RangeTransform: give min_in with min_out and max_in with max_out",
                ))
            }
        };
        if scale != 1.0 || offset != 0.0 {
            ops.push(Op::Matrix {
                m: IDENTITY.map(|r| r.map(|v| v * scale)),
                offset: [offset; 3],
            });
        }
        if clamp {
            ops.push(Op::Clamp {
                min: min_out.map_or(f32::NEG_INFINITY, |v| v as f32),
                max: max_out.map_or(f32::INFINITY, |v| v as f32),
            });
        }
        Ok(ops)
    }

    fn file_ops(&self, node: &Node) -> Result<Vec<Op>, SceneError> {
        let src =
            text(node, "src").ok_or_else(|| self.at(node.line, "FileTransform without src"))?;
        let interp = match text(node, "interpolation").as_deref().unwrap_or("linear") {
            "linear" | "trilinear" | "default" | "best" | "nearest" => Interpolation::Linear,
            "tetrahedral" => Interpolation::Tetrahedral,
            i => {
                return Err(self.at(
                    node.line,
                    format!("FileTransform: unknown interpolation \"{i}\""),
                ))
            }
        };
        let candidates: Vec<PathBuf> = self.search_paths.iter().map(|d| d.join(&src)).collect();
        let Some(path) = candidates.iter().find(|p| p.is_file()) else {
            return Err(SceneError::NotFound {
                name: src,
                searched: candidates,
                from: Some(Location::new(self.file.clone(), node.line)),
            });
        };
        let key = (path.clone(), interp);
        if let Some(ops) = self.luts.lock().ok().and_then(|c| c.get(&key).cloned()) {
            return Ok(ops);
        }
        let ops = read_lut(path, interp)?;
        if let Ok(mut cache) = self.luts.lock() {
            cache.insert(key, ops.clone());
        }
        Ok(ops)
    }
}

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

fn sum3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
