//! Lua scene scripts: `yubin render scene.lua` runs a Lua 5.4 script that
//! builds the scene through a `gr` table, in the spirit of seed 000 (and
//! the CS488 ray tracer it grew from). The script describes objects as the
//! XML front end does, and the same builder makes the scene, so a script
//! and the XML written by hand for the same scene render the same image.
//!
//! ```lua
//! uv_scale = 0.5
//! metalplate = gr.material({
//!   albedo = gr.image("tex/Metal_Plate_007_COLOR.png", true, uv_scale, 1.0),
//!   normal = gr.image("tex/Metal_Plate_007_NORM.png", false, uv_scale),
//!   roughness = gr.image("tex/Metal_Plate_007_ROUGH_fix.png", false, uv_scale),
//!   metallic = gr.const(1.0),
//! })
//! root = gr.node("root")
//! ball = gr.sphere("ball")
//! ball:set_material(metalplate)
//! ball:translate(0, 1, 0)
//! root:add_child(ball)
//! gr.render{scene = root, output = "ball.png", width = 640, height = 480,
//!           eye = {0, 2, 8}, view = {0, -0.2, -1}, up = {0, 1, 0}, fov = 40,
//!           lights = {gr.light({4, 6, 4}, {40, 40, 40})}, ambient = {0.1, 0.1, 0.1}}
//! ```
//!
//! | function | makes |
//! |---|---|
//! | `gr.const(v)`, `gr.const(r, g, b)` | a constant (one number is grey) |
//! | `gr.image(path, srgb, uv_scale, value_scale)` or `gr.image(path, {srgb=, uv_scale=, value_scale=})` | a `bitmap` texture: `srgb` (default true) decodes sRGB, `uv_scale` multiplies uv, `value_scale` the values (a `scale` texture) |
//! | `gr.material{albedo=, roughness=, metallic=, specular=, normal=, emission=}` | a `principled` BSDF (numbers, `{r, g, b}`, `gr.const` or `gr.image` for each); `normal` a tangent-space normal map (`normalmap`), `emission` the radiance of an area light on every shape that wears it |
//! | `gr.node(name)` | a transform node |
//! | `gr.sphere(name)`, `gr.cube(name)` | the unit sphere at the origin, the cube [0, 1]³ (CS488's) |
//! | `gr.mesh(name, path)` | an OBJ or PLY mesh |
//! | `gr.sdf(name, tree, options)` | a ray-marched `sdf` shape: `tree` is a node table `{type = "smooth_union", k = 0.1, {type = "sphere", radius = 0.5}, {type = "box", half_size = {1, 1, 1}}}` (the XML `<sdf>` types and parameters by name, children in the array part, and optional `scale`, `rotate = {axis, degrees}`, `translate` per node); `options` the shape's own (`step_factor`, `bbox_min`, ...) |
//! | `gr.mandelbox(name, options)` | the `mandelbox` shape (`scale`, `iterations`, ..., and the marching options) |
//! | `gr.load(path)` | a glTF model (`.gltf`, `.glb`) as a node, or a Mitsuba XML scene's shapes and emitters (at the top level only) |
//! | `node:translate(x, y, z)`, `node:rotate(axis, degrees)`, `node:scale(x, y, z)` | transforms applied after the node's earlier ones (`axis` `'x'`, `'y'` or `'z'`) |
//! | `node:add_child(child)`, `node:set_material(m)` | the hierarchy; a node without material wears its parent's |
//! | `gr.light(position, colour)` | a point light of that radiant intensity (a third CS488 falloff argument is ignored: the falloff is physical) |
//! | `gr.camera{eye=, view= or target=, up=, fov=}` | a camera, for `gr.render{camera = ...}` |
//! | `gr.render{scene=, output=, width=, height=, spp=, camera= or eye=, view= or target=, up=, fov=, lights=, ambient=, env=, max_depth=}` | the render: the camera (vertical `fov` in degrees), lights, a constant `ambient` environment, an `env` map; also CS488's `gr.render(root, output, w, h, eye, view, up, fov, ambient, lights)` |
//!
//! **Animation**: the script runs once per frame with the globals `frame`
//! (its number) and `time` (seconds, `frame / fps`), and shapes motion
//! with the easing curves of the `ease` table (`ease.linear`, `in_quad`,
//! `out_quad`, `in_out_quad`, `in_cubic`, `out_cubic`, `in_out_cubic`,
//! and seed 000's `ease.cosine`, ½ − ½ cos πt), all of t ∈ [0, 1], and
//! `ease.between(a, b, t, curve)` for numbers or `{x, y, z}`. Between
//! frames, what the description changes is applied to the scene through
//! the scene-parameter interface ([`LuaAnimation`]); each frame is the
//! image its scene built alone gives.
//!
//! Errors carry the script's name and line (`scene.lua:12: ...`). The
//! script runs sandboxed: only Lua's `table`, `string`, `math`, `utf8` and
//! `coroutine` libraries (no `os`, `io`, `package`, `require`, `load`ing
//! of files or `debug`), so it can neither run programs nor write files,
//! and the files `gr` reads must lie below the script's directory unless
//! `--allow-read` says otherwise.

use crate::desc::{Category, Child, Object, Property, SceneDesc, Value};
use crate::error::{Location, SceneError};
use glam::{DMat4, DVec3};
use mlua::{AnyUserData, Lua, StdLib, Table, UserData, UserDataMethods, Value as LuaValue};
use std::cell::{Cell, RefCell};
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

/// What a script may do beyond the sandbox.
#[derive(Clone, Debug, Default)]
pub struct LuaOptions {
    /// Read files anywhere (default: below the script's directory only).
    pub allow_read_anywhere: bool,
}

/// A script's scene and the output it names.
#[derive(Debug)]
pub struct LuaScene {
    /// The scene, as the XML front end would describe it.
    pub desc: SceneDesc,
    /// `gr.render`'s `output` (relative to the current directory, as
    /// `-o` is).
    pub output: Option<PathBuf>,
}

/// Whether `path` names a Lua script (by its extension).
pub fn is_lua(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("lua"))
}

/// Runs the script and builds its scene.
pub fn load_lua(
    path: &Path,
    options: &LuaOptions,
) -> Result<(crate::LoadedScene, Option<PathBuf>), SceneError> {
    let scene = run_lua(path, options)?;
    Ok((crate::build::build_scene(&scene.desc)?, scene.output))
}

/// Runs the script: the scene its `gr.render` call describes.
pub fn run_lua(path: &Path, options: &LuaOptions) -> Result<LuaScene, SceneError> {
    run_lua_at(path, options, None)
}

/// [`run_lua`] at frame `frame` of an animation at `fps` frames per
/// second: the script sees `frame` and `time` (seconds, `frame / fps`).
pub fn run_lua_at(
    path: &Path,
    options: &LuaOptions,
    at: Option<(i64, f64)>,
) -> Result<LuaScene, SceneError> {
    run_lua_limited(path, options, at, Limits::default())
}

/// Budgets for a script's run; none by default, since `yubin render`
/// runs scripts their own authors wrote. The fuzz harnesses set both so
/// that an endless loop or a runaway string is an error, not a hang.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Limits {
    /// Lua VM instructions, over all coroutines together.
    pub instructions: Option<u64>,
    /// Bytes the Lua state may hold.
    pub memory: Option<usize>,
}

/// [`run_lua_at`] within `limits`.
pub(crate) fn run_lua_limited(
    path: &Path,
    options: &LuaOptions,
    at: Option<(i64, f64)>,
    limits: Limits,
) -> Result<LuaScene, SceneError> {
    let file = Arc::new(path.to_path_buf());
    let whole = Location::new(file.clone(), 0);
    let source =
        std::fs::read_to_string(path).map_err(|e| SceneError::at(&whole, e.to_string()))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let dir = if dir.as_os_str().is_empty() {
        PathBuf::from(".")
    } else {
        dir
    };
    let ctx = Rc::new(Ctx {
        dir: dir.clone(),
        root_dir: dir.canonicalize().unwrap_or(dir.clone()),
        allow_anywhere: options.allow_read_anywhere,
        loc: Location::new(file.clone(), 0),
        render: RefCell::new(None),
    });
    let lua = sandbox().map_err(|e| lua_error(&file, e))?;
    limit(&lua, limits).map_err(|e| lua_error(&file, e))?;
    install_gr(&lua, &ctx).map_err(|e| lua_error(&file, e))?;
    install_ease(&lua).map_err(|e| lua_error(&file, e))?;
    let (frame, time) = at.map_or((0, 0.0), |(f, fps)| (f, f as f64 / fps));
    let globals = lua.globals();
    globals
        .set("frame", frame)
        .map_err(|e| lua_error(&file, e))?;
    globals.set("time", time).map_err(|e| lua_error(&file, e))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    lua.load(&source)
        .set_name(format!("@{name}"))
        .exec()
        .map_err(|e| lua_error(&file, e))?;
    let render = ctx.render.borrow_mut().take();
    let render =
        render.ok_or_else(|| SceneError::at(&whole, "the script never calls gr.render"))?;
    let output = render.output.clone().map(PathBuf::from);
    Ok(LuaScene {
        desc: scene_desc(&ctx, render, path)?,
        output,
    })
}

/// A Lua state with only the libraries that can neither reach the
/// system nor load code from files.
fn sandbox() -> mlua::Result<Lua> {
    let libs = StdLib::TABLE | StdLib::STRING | StdLib::MATH | StdLib::UTF8 | StdLib::COROUTINE;
    let lua = Lua::new_with(libs, mlua::LuaOptions::new())?;
    let globals = lua.globals();
    for name in ["dofile", "loadfile", "load", "require", "collectgarbage"] {
        globals.set(name, LuaValue::Nil)?;
    }
    Ok(lua)
}

/// Installs `limits` on a fresh state. The instruction count is checked
/// every thousand instructions.
fn limit(lua: &Lua, limits: Limits) -> mlua::Result<()> {
    if let Some(bytes) = limits.memory {
        lua.set_memory_limit(bytes)?;
    }
    if let Some(max) = limits.instructions {
        // mlua 0.10 calls a hook only on the thread it was set on, so a
        // loop inside a coroutine would escape the count: a limited
        // script has no coroutines.
        lua.globals().set("coroutine", LuaValue::Nil)?;
        const EVERY: u32 = 1000;
        let spent = Cell::new(0u64);
        lua.set_hook(
            mlua::HookTriggers::new().every_nth_instruction(EVERY),
            move |_, _| {
                spent.set(spent.get() + u64::from(EVERY));
                if spent.get() > max {
                    return Err(mlua::Error::runtime(format!(
                        "the script ran more than {max} Lua instructions"
                    )));
                }
                Ok(mlua::VmState::Continue)
            },
        );
    }
    Ok(())
}

/// `scene.lua:12: message` as an error at that line.
fn lua_error(file: &Arc<PathBuf>, e: mlua::Error) -> SceneError {
    let msg = innermost(&e);
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let located = msg
        .strip_prefix(&format!("{name}:"))
        .and_then(|rest| rest.split_once(':'))
        .and_then(|(line, rest)| Some((line.trim().parse::<u32>().ok()?, rest.trim())));
    match located {
        Some((line, rest)) => SceneError::at(&Location::new(file.clone(), line), rest.to_string()),
        // A value a `gr` function could not take: the line that called it
        // is the script's first frame in the traceback.
        None => {
            let line = traceback_line(&e, &name).unwrap_or(0);
            SceneError::at(&Location::new(file.clone(), line), msg)
        }
    }
}

/// The first line of the script (`name:LINE:`) in the error's traceback.
fn traceback_line(e: &mlua::Error, name: &str) -> Option<u32> {
    let mlua::Error::CallbackError { traceback, cause } = e else {
        return None;
    };
    let prefix = format!("{name}:");
    traceback
        .lines()
        .filter_map(|l| l.trim().strip_prefix(&prefix))
        .find_map(|rest| rest.split_once(':')?.0.parse().ok())
        .or_else(|| traceback_line(cause, name))
}

/// The message of the error a callback raised, without mlua's wrapping.
fn innermost(e: &mlua::Error) -> String {
    match e {
        mlua::Error::CallbackError { cause, .. } => innermost(cause),
        mlua::Error::RuntimeError(m) | mlua::Error::SyntaxError { message: m, .. } => {
            // The message, without the traceback Lua appends.
            m.split("\nstack traceback:")
                .next()
                .unwrap_or(m)
                .to_string()
        }
        other => other.to_string(),
    }
}

/// The script's position (`scene.lua:12`) where a `gr` function was
/// called.
fn here(lua: &Lua) -> String {
    lua.inspect_stack(1)
        .map(|d| {
            let s = d.source();
            format!("{}:{}", s.short_src.unwrap_or_default(), d.curr_line())
        })
        .unwrap_or_default()
}

fn fail(lua: &Lua, msg: impl std::fmt::Display) -> mlua::Error {
    mlua::Error::RuntimeError(format!("{}: {msg}", here(lua)))
}

/// What every `gr` function shares.
struct Ctx {
    dir: PathBuf,
    root_dir: PathBuf,
    allow_anywhere: bool,
    loc: Location,
    render: RefCell<Option<Render>>,
}

impl Ctx {
    /// A file the script names, found below its directory (unless reading
    /// anywhere is allowed), as an absolute path.
    fn file(&self, lua: &Lua, what: &str, name: &str) -> mlua::Result<PathBuf> {
        let path = self.dir.join(name);
        let found = path
            .canonicalize()
            .map_err(|e| fail(lua, format!("{what}: \"{name}\": {e}")))?;
        if !self.allow_anywhere && !found.starts_with(&self.root_dir) {
            return Err(fail(
                lua,
                format!(
                    "{what}: \"{name}\" lies outside the script's directory {}; \
                     --allow-read lets a script read anywhere",
                    self.root_dir.display()
                ),
            ));
        }
        Ok(found)
    }

    fn prop(&self, name: &str, value: Value) -> Property {
        Property {
            name: name.to_string(),
            value,
            loc: self.loc.clone(),
            used: Cell::new(false),
            look_at_target: None,
        }
    }

    fn object(&self, category: Category, kind: &str, props: Vec<Property>) -> Object {
        let mut o = Object::new(category, kind, self.loc.clone());
        o.props = props;
        o
    }

    fn child(&self, name: Option<&str>, object: Rc<Object>) -> Child {
        Child {
            name: name.map(str::to_string),
            object,
            loc: self.loc.clone(),
            used: Cell::new(false),
        }
    }

    /// Where the script calls the running `gr` function: its line, so
    /// that the builder's errors about what it made name that line.
    fn call_site(&self, lua: &Lua) -> Location {
        let line = lua
            .inspect_stack(1)
            .map_or(0, |d| d.curr_line().max(0) as u32);
        Location::new(self.loc.file.clone(), line)
    }

    /// The string-keyed entries of `t` as parameters: integers, numbers,
    /// booleans, strings and `{x, y, z}` (a vector). `skip` names keys
    /// read elsewhere.
    fn props_of(
        &self,
        lua: &Lua,
        t: &Table,
        what: &str,
        skip: &[&str],
    ) -> mlua::Result<Vec<Property>> {
        let loc = self.call_site(lua);
        let mut props = Vec::new();
        for pair in t.pairs::<LuaValue, LuaValue>() {
            let (key, value) = pair?;
            let LuaValue::String(key) = key else {
                continue;
            };
            let key = key.to_str()?.to_string();
            if skip.contains(&key.as_str()) {
                continue;
            }
            let value = match value {
                LuaValue::Integer(i) => Value::Integer(i),
                LuaValue::Number(x) => Value::Float(x),
                LuaValue::Boolean(b) => Value::Boolean(b),
                LuaValue::String(v) => Value::String(v.to_str()?.to_string()),
                LuaValue::Table(v) => {
                    Value::Vector(vec3(lua, &v, &format!("{what} {key}"))?.as_vec3())
                }
                other => {
                    return Err(fail(
                        lua,
                        format!("{what}: {key} cannot be a {}", other.type_name()),
                    ))
                }
            };
            let mut p = self.prop(&key, value);
            p.loc = loc.clone();
            props.push(p);
        }
        // Table order is unspecified: sorted, so descriptions compare.
        props.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(props)
    }

    /// An `<sdf>` node from a table: `type`, its parameters, optional
    /// `scale` (a number or `{x, y, z}`), `rotate` (`{axis, degrees}`) and
    /// `translate` (`{x, y, z}`), applied in that order, and its children
    /// in the table's array part.
    fn sdf_node(&self, lua: &Lua, t: &Table, depth: usize) -> mlua::Result<Rc<Object>> {
        if depth > yubin_core::shape::sdf_tree::MAX_DEPTH {
            return Err(fail(lua, "gr.sdf: nodes nest too deep"));
        }
        let kind: String = t
            .get::<Option<String>>("type")?
            .ok_or_else(|| fail(lua, "gr.sdf: every node needs a type"))?;
        let mut props =
            self.props_of(lua, t, "gr.sdf", &["type", "scale", "rotate", "translate"])?;
        let mut m = DMat4::IDENTITY;
        match t.get::<LuaValue>("scale")? {
            LuaValue::Nil => {}
            LuaValue::Integer(i) => m = DMat4::from_scale(DVec3::splat(i as f64)),
            LuaValue::Number(x) => m = DMat4::from_scale(DVec3::splat(x)),
            LuaValue::Table(v) => m = DMat4::from_scale(vec3(lua, &v, "gr.sdf scale")?),
            _ => return Err(fail(lua, "gr.sdf: scale is a number or {x, y, z}")),
        }
        if let Some(r) = t.get::<Option<Table>>("rotate")? {
            let axis: String = r.get(1)?;
            let degrees: f64 = r.get(2)?;
            let axis = match axis.as_str() {
                "x" | "X" => DVec3::X,
                "y" | "Y" => DVec3::Y,
                "z" | "Z" => DVec3::Z,
                _ => return Err(fail(lua, "gr.sdf: rotate = {'x'|'y'|'z', degrees}")),
            };
            m = DMat4::from_axis_angle(axis, degrees.to_radians()) * m;
        }
        if let Some(v) = t.get::<Option<Table>>("translate")? {
            m = DMat4::from_translation(vec3(lua, &v, "gr.sdf translate")?) * m;
        }
        let loc = self.call_site(lua);
        if m != DMat4::IDENTITY {
            let mut p = self.prop("to_world", Value::Transform(m));
            p.loc = loc.clone();
            props.push(p);
        }
        let mut o = Object::new(Category::Sdf, &kind, loc);
        o.props = props;
        for child in t.sequence_values::<Table>() {
            let node = self.sdf_node(lua, &child?, depth + 1)?;
            o.children.push(self.child(None, node));
        }
        Ok(Rc::new(o))
    }
}

/// `{x, y, z}` as a vector.
fn vec3(lua: &Lua, t: &Table, what: &str) -> mlua::Result<DVec3> {
    let get = |i| t.get::<f64>(i);
    match (get(1), get(2), get(3), t.raw_len()) {
        (Ok(x), Ok(y), Ok(z), 3) => Ok(DVec3::new(x, y, z)),
        _ => Err(fail(lua, format!("{what}: expects {{x, y, z}}"))),
    }
}

/// A texture or constant value (`gr.const`, `gr.image`).
#[derive(Clone, Debug)]
enum TexVal {
    Const([f64; 3]),
    Texture(Rc<Object>),
}

impl UserData for TexVal {}

/// A material (`gr.material`).
#[derive(Clone, Debug)]
struct Mat {
    bsdf: Rc<Object>,
    emission: Option<TexVal>,
}

impl UserData for Mat {}

/// A point light (`gr.light`).
#[derive(Clone, Debug)]
struct Light {
    position: DVec3,
    colour: [f64; 3],
}

impl UserData for Light {}

/// What a node draws.
#[derive(Clone, Debug)]
enum Geometry {
    None,
    Sphere,
    Cube,
    Mesh(PathBuf),
    Gltf(PathBuf),
    /// A Mitsuba XML scene's shapes and emitters, and its directory.
    Xml(Vec<Rc<Object>>, PathBuf),
    /// A ray-marched shape (`sdf` or `mandelbox`): its type, its own
    /// parameters and its nested `<sdf>` nodes.
    Marched(&'static str, Vec<Property>, Vec<Rc<Object>>),
}

#[derive(Debug)]
struct NodeData {
    transform: DMat4,
    geometry: Geometry,
    material: Option<Mat>,
    children: Vec<Node>,
}

/// A node of the hierarchy (`gr.node`, `gr.sphere`, ...).
#[derive(Clone, Debug)]
struct Node(Rc<RefCell<NodeData>>);

impl Node {
    fn new(geometry: Geometry) -> Self {
        Node(Rc::new(RefCell::new(NodeData {
            transform: DMat4::IDENTITY,
            geometry,
            material: None,
            children: Vec::new(),
        })))
    }

    fn apply(&self, m: DMat4) {
        let mut d = self.0.borrow_mut();
        d.transform = m * d.transform;
    }
}

impl UserData for Node {
    fn add_methods<M: UserDataMethods<Self>>(methods: &mut M) {
        methods.add_method("translate", |_, this, (x, y, z): (f64, f64, f64)| {
            this.apply(DMat4::from_translation(DVec3::new(x, y, z)));
            Ok(())
        });
        methods.add_method(
            "scale",
            |_, this, (x, y, z): (f64, Option<f64>, Option<f64>)| {
                let s = DVec3::new(x, y.unwrap_or(x), z.unwrap_or(x));
                this.apply(DMat4::from_scale(s));
                Ok(())
            },
        );
        methods.add_method("rotate", |lua, this, (axis, degrees): (String, f64)| {
            let a = degrees.to_radians();
            let m = match axis.to_ascii_lowercase().as_str() {
                "x" => DMat4::from_rotation_x(a),
                "y" => DMat4::from_rotation_y(a),
                "z" => DMat4::from_rotation_z(a),
                other => {
                    return Err(fail(
                        lua,
                        format!("rotate: axis \"{other}\" is not x, y or z"),
                    ))
                }
            };
            this.apply(m);
            Ok(())
        });
        methods.add_method("add_child", |lua, this, child: AnyUserData| {
            let child: Node = value_of(lua, &child, "add_child: the child must be a node")?;
            if Rc::ptr_eq(&this.0, &child.0) {
                return Err(fail(lua, "add_child: a node cannot be its own child"));
            }
            this.0.borrow_mut().children.push(child);
            Ok(())
        });
        methods.add_method("set_material", |lua, this, m: AnyUserData| {
            let m: Mat = value_of(lua, &m, "set_material: expects a gr.material")?;
            this.0.borrow_mut().material = Some(m);
            Ok(())
        });
    }
}

/// `gr.render`'s settings.
#[derive(Debug)]
struct Render {
    scene: Node,
    output: Option<String>,
    width: i64,
    height: i64,
    spp: i64,
    eye: DVec3,
    target: DVec3,
    up: DVec3,
    fov: f64,
    lights: Vec<Light>,
    ambient: [f64; 3],
    env: Option<PathBuf>,
    max_depth: Option<i64>,
}

/// The `T` a userdata holds, or the error `wrong` at the script's line.
fn value_of<T: Clone + 'static>(lua: &Lua, ud: &AnyUserData, wrong: &str) -> mlua::Result<T> {
    ud.borrow::<T>()
        .map(|v| v.clone())
        .map_err(|_| fail(lua, wrong))
}

/// Three numbers from a table `{x, y, z}` (or one number, repeated).
fn triple(lua: &Lua, what: &str, v: &LuaValue) -> mlua::Result<[f64; 3]> {
    match v {
        LuaValue::Number(n) => Ok([*n; 3]),
        LuaValue::Integer(n) => Ok([*n as f64; 3]),
        LuaValue::Table(t) => {
            let get = |i: i64| t.get::<f64>(i);
            match (get(1), get(2), get(3)) {
                (Ok(a), Ok(b), Ok(c)) => Ok([a, b, c]),
                _ => Err(fail(
                    lua,
                    format!("{what}: expects three numbers {{x, y, z}}"),
                )),
            }
        }
        _ => Err(fail(
            lua,
            format!("{what}: expects three numbers {{x, y, z}}"),
        )),
    }
}

/// A texture-valued argument: a number, `{r, g, b}`, `gr.const` or
/// `gr.image`.
fn tex_value(lua: &Lua, what: &str, v: &LuaValue) -> mlua::Result<TexVal> {
    match v {
        LuaValue::UserData(ud) => ud.borrow::<TexVal>().map(|t| t.clone()).map_err(|_| {
            fail(
                lua,
                format!("{what}: expects a number, {{r, g, b}}, gr.const or gr.image"),
            )
        }),
        other => triple(lua, what, other).map(TexVal::Const),
    }
}

fn install_gr(lua: &Lua, ctx: &Rc<Ctx>) -> mlua::Result<()> {
    let gr = lua.create_table()?;
    gr.set(
        "const",
        lua.create_function(|_, (r, g, b): (f64, Option<f64>, Option<f64>)| {
            Ok(TexVal::Const([r, g.unwrap_or(r), b.unwrap_or(r)]))
        })?,
    )?;
    let c = ctx.clone();
    gr.set(
        "image",
        lua.create_function(
            move |lua, (path, a, b, d): (String, LuaValue, Option<f64>, Option<f64>)| {
                let (srgb, uv_scale, value_scale) = match &a {
                    LuaValue::Table(t) => (
                        t.get::<Option<bool>>("srgb")?.unwrap_or(true),
                        t.get::<Option<f64>>("uv_scale")?.unwrap_or(1.0),
                        t.get::<Option<f64>>("value_scale")?.unwrap_or(1.0),
                    ),
                    LuaValue::Boolean(s) => (*s, b.unwrap_or(1.0), d.unwrap_or(1.0)),
                    LuaValue::Nil => (true, b.unwrap_or(1.0), d.unwrap_or(1.0)),
                    _ => {
                        return Err(fail(
                            lua,
                            "gr.image: the second argument is srgb or an options table",
                        ))
                    }
                };
                let file = c.file(lua, "gr.image", &path)?;
                let mut props = vec![c.prop(
                    "filename",
                    Value::String(file.to_string_lossy().into_owned()),
                )];
                if !srgb {
                    props.push(c.prop("raw", Value::Boolean(true)));
                }
                if uv_scale != 1.0 {
                    let s = DMat4::from_scale(DVec3::new(uv_scale, uv_scale, 1.0));
                    props.push(c.prop("to_uv", Value::Transform(s)));
                }
                let bitmap = Rc::new(c.object(Category::Texture, "bitmap", props));
                if value_scale == 1.0 {
                    return Ok(TexVal::Texture(bitmap));
                }
                let mut scaled = c.object(
                    Category::Texture,
                    "scale",
                    vec![c.prop("scale", Value::Float(value_scale))],
                );
                scaled.children.push(c.child(Some("texture"), bitmap));
                Ok(TexVal::Texture(Rc::new(scaled)))
            },
        )?,
    )?;
    let c = ctx.clone();
    gr.set(
        "material",
        lua.create_function(move |lua, t: Table| {
            let mut principled = c.object(Category::Bsdf, "principled", vec![]);
            let mut normal = None;
            let mut emission = None;
            // In name order: Lua's own order changes from run to run, and
            // an animation compares the description of one frame with the
            // next.
            let mut entries = t
                .pairs::<String, LuaValue>()
                .collect::<mlua::Result<Vec<_>>>()?;
            entries.sort_by(|a, b| a.0.cmp(&b.0));
            for (key, v) in entries {
                let name = match key.as_str() {
                    "albedo" | "base_color" => "base_color",
                    "roughness" | "metallic" | "specular" => key.as_str(),
                    "normal" => {
                        normal = Some(tex_value(lua, "gr.material normal", &v)?);
                        continue;
                    }
                    "emission" => {
                        emission = Some(tex_value(lua, "gr.material emission", &v)?);
                        continue;
                    }
                    other => {
                        return Err(fail(
                            lua,
                            format!(
                                "gr.material: unknown parameter \"{other}\" (albedo, roughness, \
                                 metallic, specular, normal, emission)"
                            ),
                        ))
                    }
                };
                match tex_value(lua, &format!("gr.material {key}"), &v)? {
                    TexVal::Const(rgb) if name == "base_color" => principled
                        .props
                        .push(c.prop(name, Value::Rgb(rgb.map(|x| x as f32)))),
                    TexVal::Const(rgb) => principled.props.push(c.prop(name, Value::Float(rgb[0]))),
                    TexVal::Texture(o) => principled.children.push(c.child(Some(name), o)),
                }
            }
            let mut bsdf = Rc::new(principled);
            if let Some(n) = normal {
                let TexVal::Texture(map) = n else {
                    return Err(fail(lua, "gr.material normal: expects gr.image"));
                };
                let mut nm = c.object(Category::Bsdf, "normalmap", vec![]);
                nm.children.push(c.child(Some("normalmap"), map));
                nm.children.push(c.child(None, bsdf));
                bsdf = Rc::new(nm);
            }
            Ok(Mat { bsdf, emission })
        })?,
    )?;
    gr.set(
        "node",
        lua.create_function(|_, _name: Option<String>| Ok(Node::new(Geometry::None)))?,
    )?;
    gr.set(
        "sphere",
        lua.create_function(|_, _name: Option<String>| Ok(Node::new(Geometry::Sphere)))?,
    )?;
    gr.set(
        "cube",
        lua.create_function(|_, _name: Option<String>| Ok(Node::new(Geometry::Cube)))?,
    )?;
    let c = ctx.clone();
    gr.set(
        "sdf",
        lua.create_function(
            move |lua, (_name, tree, options): (Option<String>, Table, Option<Table>)| {
                let node = c.sdf_node(lua, &tree, 0)?;
                let props = match options {
                    Some(t) => c.props_of(lua, &t, "gr.sdf", &[])?,
                    None => Vec::new(),
                };
                Ok(Node::new(Geometry::Marched("sdf", props, vec![node])))
            },
        )?,
    )?;
    let c = ctx.clone();
    gr.set(
        "mandelbox",
        lua.create_function(
            move |lua, (_name, options): (Option<String>, Option<Table>)| {
                let props = match options {
                    Some(t) => c.props_of(lua, &t, "gr.mandelbox", &[])?,
                    None => Vec::new(),
                };
                Ok(Node::new(Geometry::Marched("mandelbox", props, vec![])))
            },
        )?,
    )?;
    let c = ctx.clone();
    gr.set(
        "mesh",
        lua.create_function(move |lua, (_name, path): (String, String)| {
            Ok(Node::new(Geometry::Mesh(c.file(lua, "gr.mesh", &path)?)))
        })?,
    )?;
    let c = ctx.clone();
    gr.set(
        "load",
        lua.create_function(move |lua, path: String| {
            let file = c.file(lua, "gr.load", &path)?;
            if crate::gltf::is_gltf(&file) {
                return Ok(Node::new(Geometry::Gltf(file)));
            }
            let desc = crate::xml::parse_file(&file, &[])
                .map_err(|e| fail(lua, format!("gr.load: {e}")))?;
            let objects = desc
                .root
                .children
                .iter()
                .filter(|c| matches!(c.object.category, Category::Shape | Category::Emitter))
                .map(|c| c.object.clone())
                .collect();
            let dir = file.parent().map(Path::to_path_buf).unwrap_or_default();
            Ok(Node::new(Geometry::Xml(objects, dir)))
        })?,
    )?;
    gr.set(
        "camera",
        lua.create_function(|lua, t: Table| {
            let camera = lua.create_table()?;
            for key in ["eye", "target", "view", "up"] {
                let v: LuaValue = t.get(key)?;
                if !v.is_nil() {
                    let [x, y, z] = triple(lua, &format!("gr.camera {key}"), &v)?;
                    camera.set(key, lua.create_sequence_from([x, y, z])?)?;
                }
            }
            camera.set("fov", t.get::<Option<f64>>("fov")?)?;
            Ok(camera)
        })?,
    )?;
    gr.set(
        "light",
        lua.create_function(|lua, (p, c, _falloff): (LuaValue, LuaValue, LuaValue)| {
            Ok(Light {
                position: DVec3::from(triple(lua, "gr.light position", &p)?),
                colour: triple(lua, "gr.light colour", &c)?,
            })
        })?,
    )?;
    let c = ctx.clone();
    gr.set(
        "render",
        lua.create_function(move |lua, args: mlua::MultiValue| {
            let render = render_args(lua, &c, args)?;
            if c.render.borrow().is_some() {
                return Err(fail(lua, "gr.render: called twice (one render per script)"));
            }
            *c.render.borrow_mut() = Some(render);
            Ok(())
        })?,
    )?;
    lua.globals().set("gr", gr)
}

/// `gr.render`'s arguments, as a table or CS488's positional list.
fn render_args(lua: &Lua, ctx: &Ctx, args: mlua::MultiValue) -> mlua::Result<Render> {
    let args: Vec<LuaValue> = args.into_iter().collect();
    let named: Table = match args.first() {
        Some(LuaValue::Table(t)) => t.clone(),
        Some(LuaValue::UserData(_)) => {
            let t = lua.create_table()?;
            let names = [
                "scene", "output", "width", "height", "eye", "view", "up", "fov", "ambient",
                "lights",
            ];
            for (name, v) in names.iter().zip(args.iter()) {
                t.set(*name, v.clone())?;
            }
            t
        }
        _ => return Err(fail(lua, "gr.render: expects a table {scene = root, ...}")),
    };
    let scene: AnyUserData = named
        .get::<Option<AnyUserData>>("scene")?
        .ok_or_else(|| fail(lua, "gr.render: needs scene = a node"))?;
    let scene: Node = value_of(lua, &scene, "gr.render: scene must be a node")?;
    let vec3 = |name: &str, default: [f64; 3]| -> mlua::Result<DVec3> {
        match named.get::<LuaValue>(name)? {
            LuaValue::Nil => Ok(DVec3::from(default)),
            v => triple(lua, &format!("gr.render {name}"), &v).map(DVec3::from),
        }
    };
    // A gr.camera's settings, where the render gives none of its own.
    if let Some(camera) = named.get::<Option<Table>>("camera")? {
        for key in ["eye", "target", "view", "up", "fov"] {
            if named.get::<LuaValue>(key)?.is_nil() {
                named.set(key, camera.get::<LuaValue>(key)?)?;
            }
        }
    }
    let eye = vec3("eye", [0.0, 0.0, 5.0])?;
    let target = match named.get::<LuaValue>("target")? {
        LuaValue::Nil => eye + vec3("view", [0.0, 0.0, -1.0])?,
        v => DVec3::from(triple(lua, "gr.render target", &v)?),
    };
    let mut lights = Vec::new();
    if let Some(list) = named.get::<Option<Table>>("lights")? {
        for v in list.sequence_values::<AnyUserData>() {
            let l: Light = value_of(lua, &v?, "gr.render lights: expects gr.light values")?;
            lights.push(l);
        }
    }
    let env = match named.get::<Option<String>>("env")? {
        Some(e) => Some(ctx.file(lua, "gr.render env", &e)?),
        None => None,
    };
    Ok(Render {
        scene,
        output: named.get("output")?,
        width: named.get::<Option<i64>>("width")?.unwrap_or(640),
        height: named.get::<Option<i64>>("height")?.unwrap_or(480),
        spp: named.get::<Option<i64>>("spp")?.unwrap_or(64),
        eye,
        target,
        up: vec3("up", [0.0, 1.0, 0.0])?,
        fov: named.get::<Option<f64>>("fov")?.unwrap_or(40.0),
        lights,
        ambient: match named.get::<LuaValue>("ambient")? {
            LuaValue::Nil => [0.0; 3],
            v => triple(lua, "gr.render ambient", &v)?,
        },
        env,
        max_depth: named.get("max_depth")?,
    })
}

/// Mitsuba's `lookat`: +z towards the target, +x to the left.
fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> DMat4 {
    let dir = (target - origin).normalize();
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    )
}

/// The scene description of a finished script.
fn scene_desc(ctx: &Ctx, r: Render, path: &Path) -> Result<SceneDesc, SceneError> {
    let mut top: Vec<Rc<Object>> = Vec::new();
    let mut integrator = ctx.object(Category::Integrator, "path", vec![]);
    if let Some(d) = r.max_depth {
        integrator
            .props
            .push(ctx.prop("max_depth", Value::Integer(d)));
    }
    top.push(Rc::new(integrator));
    let mut sensor = ctx.object(
        Category::Sensor,
        "perspective",
        vec![
            ctx.prop("fov", Value::Float(r.fov)),
            ctx.prop("fov_axis", Value::String("y".into())),
            ctx.prop("to_world", Value::Transform(look_at(r.eye, r.target, r.up))),
        ],
    );
    let film = ctx.object(
        Category::Film,
        "hdrfilm",
        vec![
            ctx.prop("width", Value::Integer(r.width)),
            ctx.prop("height", Value::Integer(r.height)),
        ],
    );
    let sampler = ctx.object(
        Category::Sampler,
        "independent",
        vec![ctx.prop("sample_count", Value::Integer(r.spp))],
    );
    sensor.children.push(ctx.child(None, Rc::new(film)));
    sensor.children.push(ctx.child(None, Rc::new(sampler)));
    top.push(Rc::new(sensor));
    for l in &r.lights {
        top.push(Rc::new(ctx.object(
            Category::Emitter,
            "point",
            vec![
                ctx.prop("position", Value::Point(l.position.as_vec3())),
                ctx.prop("intensity", Value::Rgb(l.colour.map(|x| x as f32))),
            ],
        )));
    }
    if r.ambient != [0.0; 3] {
        top.push(Rc::new(ctx.object(
            Category::Emitter,
            "constant",
            vec![ctx.prop("radiance", Value::Rgb(r.ambient.map(|x| x as f32)))],
        )));
    }
    if let Some(env) = &r.env {
        top.push(Rc::new(ctx.object(
            Category::Emitter,
            "envmap",
            vec![ctx.prop(
                "filename",
                Value::String(env.to_string_lossy().into_owned()),
            )],
        )));
    }
    let mut search_paths = vec![ctx.dir.clone()];
    let mut inside = Vec::new();
    let mut walk = Walk {
        out: &mut top,
        search_paths: &mut search_paths,
        path: &mut inside,
    };
    shapes(ctx, &r.scene, DMat4::IDENTITY, None, &mut walk)?;
    let mut root = ctx.object(Category::Scene, "scene", vec![]);
    root.children = top.into_iter().map(|o| ctx.child(None, o)).collect();
    Ok(SceneDesc {
        root: Rc::new(root),
        version: (3, 0, 0),
        file: path.to_path_buf(),
        search_paths,
    })
}

/// The shapes of `node` and its children, placed by `parent` and wearing
/// `inherited` where they have no material of their own; the directories
/// of loaded XML scenes join the search paths.
fn shapes(
    ctx: &Ctx,
    node: &Node,
    parent: DMat4,
    inherited: Option<&Mat>,
    walk: &mut Walk,
) -> Result<(), SceneError> {
    let here = Rc::as_ptr(&node.0) as usize;
    if walk.path.contains(&here) {
        return Err(SceneError::at(
            &ctx.loc,
            "a node is its own ancestor (add_child made a cycle)",
        ));
    }
    walk.path.push(here);
    let done = node_shapes(ctx, node, parent, inherited, walk);
    walk.path.pop();
    done
}

/// Where [`shapes`] puts what it finds, and the nodes it is inside.
struct Walk<'a> {
    out: &'a mut Vec<Rc<Object>>,
    search_paths: &'a mut Vec<PathBuf>,
    path: &'a mut Vec<usize>,
}

fn node_shapes(
    ctx: &Ctx,
    node: &Node,
    parent: DMat4,
    inherited: Option<&Mat>,
    walk: &mut Walk,
) -> Result<(), SceneError> {
    let d = node.0.borrow();
    let m = parent * d.transform;
    let material = d.material.as_ref().or(inherited);
    let shape = |kind: &str, to_world: DMat4, extra: Vec<Property>, nested: &[Rc<Object>]| {
        let mut props = vec![ctx.prop("to_world", Value::Transform(to_world))];
        props.extend(extra);
        let mut o = ctx.object(Category::Shape, kind, props);
        o.children
            .extend(nested.iter().map(|n| ctx.child(None, n.clone())));
        if let Some(mat) = material {
            o.children.push(ctx.child(None, mat.bsdf.clone()));
            if let Some(e) = &mat.emission {
                let mut area = ctx.object(Category::Emitter, "area", vec![]);
                match e {
                    TexVal::Const(rgb) => area
                        .props
                        .push(ctx.prop("radiance", Value::Rgb(rgb.map(|x| x as f32)))),
                    TexVal::Texture(t) => {
                        area.children.push(ctx.child(Some("radiance"), t.clone()))
                    }
                }
                o.children.push(ctx.child(None, Rc::new(area)));
            }
        }
        Rc::new(o)
    };
    let path_prop =
        |p: &Path| ctx.prop("filename", Value::String(p.to_string_lossy().into_owned()));
    match &d.geometry {
        Geometry::None => {}
        Geometry::Sphere => walk.out.push(shape("sphere", m, vec![], &[])),
        // CS488's cube is [0, 1]³; Mitsuba's [−1, 1]³.
        Geometry::Cube => walk.out.push(shape(
            "cube",
            m * DMat4::from_translation(DVec3::splat(0.5)) * DMat4::from_scale(DVec3::splat(0.5)),
            vec![],
            &[],
        )),
        Geometry::Mesh(p) => {
            let kind = match p.extension().and_then(|e| e.to_str()) {
                Some(e) if e.eq_ignore_ascii_case("ply") => "ply",
                _ => "obj",
            };
            walk.out.push(shape(kind, m, vec![path_prop(p)], &[]));
        }
        Geometry::Gltf(p) => {
            let o = ctx.object(
                Category::Shape,
                "gltf",
                vec![path_prop(p), ctx.prop("to_world", Value::Transform(m))],
            );
            walk.out.push(Rc::new(o));
        }
        Geometry::Marched(kind, props, nodes) => {
            walk.out.push(shape(kind, m, props.clone(), nodes));
        }
        Geometry::Xml(objects, dir) => {
            // Its shapes and emitters, where the XML put them.
            if m != DMat4::IDENTITY {
                return Err(SceneError::at(
                    &ctx.loc,
                    format!(
                        "gr.load of an XML scene ({}) cannot be transformed: its shapes keep \
                         their own to_world (load it into the root node)",
                        dir.display()
                    ),
                ));
            }
            walk.out.extend(objects.iter().cloned());
            walk.search_paths.push(dir.clone());
        }
    }
    for child in &d.children {
        shapes(ctx, child, m, material, walk)?;
    }
    Ok(())
}

/// An easing curve.
type Curve = fn(f64) -> f64;

/// The easing curves animations shape their motion with: functions of
/// t ∈ [0, 1] (clamped) from 0 to 1.
fn install_ease(lua: &Lua) -> mlua::Result<()> {
    let ease = lua.create_table()?;
    let curves: [(&str, Curve); 8] = [
        ("linear", |t| t),
        ("in_quad", |t| t * t),
        ("out_quad", |t| t * (2.0 - t)),
        ("in_out_quad", |t| {
            if t < 0.5 {
                2.0 * t * t
            } else {
                1.0 - 2.0 * (1.0 - t) * (1.0 - t)
            }
        }),
        ("in_cubic", |t| t * t * t),
        ("out_cubic", |t| 1.0 - (1.0 - t).powi(3)),
        ("in_out_cubic", |t| {
            if t < 0.5 {
                4.0 * t * t * t
            } else {
                1.0 - 4.0 * (1.0 - t).powi(3)
            }
        }),
        // Seed 000's: half a cosine period, slow at both ends.
        ("cosine", |t| 0.5 - 0.5 * (std::f64::consts::PI * t).cos()),
    ];
    for (name, f) in curves {
        ease.set(
            name,
            lua.create_function(move |_, t: f64| Ok(f(t.clamp(0.0, 1.0))))?,
        )?;
    }
    // ease.between(a, b, t, curve): a + (b − a) · curve(t), for numbers or
    // {x, y, z} tables.
    ease.set(
        "between",
        lua.create_function(
            |lua, (a, b, t, curve): (LuaValue, LuaValue, f64, Option<mlua::Function>)| {
                let w = match curve {
                    Some(f) => f.call::<f64>(t)?,
                    None => t.clamp(0.0, 1.0),
                };
                match (&a, &b) {
                    (LuaValue::Table(_), _) | (_, LuaValue::Table(_)) => {
                        let (a, b) = (
                            triple(lua, "ease.between", &a)?,
                            triple(lua, "ease.between", &b)?,
                        );
                        let out = lua.create_table()?;
                        for k in 0..3 {
                            out.set(k + 1, a[k] + (b[k] - a[k]) * w)?;
                        }
                        Ok(LuaValue::Table(out))
                    }
                    _ => {
                        let (a, b) = (
                            triple(lua, "ease.between", &a)?[0],
                            triple(lua, "ease.between", &b)?[0],
                        );
                        Ok(LuaValue::Number(a + (b - a) * w))
                    }
                }
            },
        )?,
    )?;
    lua.globals().set("ease", ease)
}

/// A Lua scene rendered frame after frame: the script runs again for each
/// frame, and what its description changes is applied to the scene built
/// for the first frame through the scene-parameter interface
/// (`Scene::update`), not by building it again. Where a frame changes the
/// description's structure (an object added or removed) or a value that
/// is not an editable parameter, that frame's scene is built afresh.
pub struct LuaAnimation {
    path: PathBuf,
    options: LuaOptions,
    fps: f64,
    current: Option<(SceneDesc, crate::LoadedScene)>,
    /// Frames whose scene was built afresh (the first included).
    pub rebuilds: u32,
    /// Parameters updated in place, over all frames.
    pub updates: u32,
}

impl std::fmt::Debug for LuaAnimation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LuaAnimation")
            .field("path", &self.path)
            .field("fps", &self.fps)
            .field("rebuilds", &self.rebuilds)
            .field("updates", &self.updates)
            .finish()
    }
}

impl LuaAnimation {
    /// The animation of the script at `path`, at `fps` frames per second.
    pub fn new(path: &Path, options: LuaOptions, fps: f64) -> Self {
        Self {
            path: path.to_path_buf(),
            options,
            fps,
            current: None,
            rebuilds: 0,
            updates: 0,
        }
    }

    /// The scene at frame `frame`, and the output its `gr.render` names.
    pub fn frame(
        &mut self,
        frame: i64,
    ) -> Result<(&crate::LoadedScene, Option<PathBuf>), SceneError> {
        let next = run_lua_at(&self.path, &self.options, Some((frame, self.fps)))?;
        let updated = match &mut self.current {
            Some((desc, loaded)) => {
                let changes = changes(desc, &next.desc, loaded);
                let applied = changes.and_then(|list| {
                    let n = list.len() as u32;
                    list.into_iter()
                        .try_for_each(|(key, value)| loaded.scene.update(&key, value).map(drop))
                        .ok()
                        .map(|()| n)
                });
                applied.inspect(|n| self.updates += n).is_some()
            }
            None => false,
        };
        if !updated {
            let loaded = crate::build::build_scene(&next.desc)?;
            self.current = Some((next.desc, loaded));
            self.rebuilds += 1;
        }
        let loaded = &self
            .current
            .as_ref()
            .expect("a scene was built or updated")
            .1;
        Ok((loaded, next.output))
    }
}

/// The parameter updates that turn the scene built from `built` into the
/// one `next` describes: `None` where they cannot (another structure, a
/// changed value that is not an editable parameter).
fn changes(
    built: &SceneDesc,
    next: &SceneDesc,
    loaded: &crate::LoadedScene,
) -> Option<Vec<(String, yubin_core::params::ParamValue)>> {
    let params: std::collections::HashMap<String, yubin_core::params::Parameter> = loaded
        .scene
        .parameters()
        .into_iter()
        .map(|p| (p.key.clone(), p))
        .collect();
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
    diff(
        &built.root,
        &next.root,
        loaded,
        &params,
        &mut out,
        &mut seen,
    )
    .then_some(out)
}

/// Walks two descriptions of the same shape side by side, collecting the
/// updates of the values that differ; false where the shapes differ or a
/// value cannot be updated.
fn diff(
    a: &Rc<Object>,
    b: &Rc<Object>,
    loaded: &crate::LoadedScene,
    params: &std::collections::HashMap<String, yubin_core::params::Parameter>,
    out: &mut Vec<(String, yubin_core::params::ParamValue)>,
    seen: &mut std::collections::HashSet<usize>,
) -> bool {
    if a.category != b.category
        || a.plugin_type != b.plugin_type
        || a.props.len() != b.props.len()
        || a.children.len() != b.children.len()
    {
        return false;
    }
    // A shared object (a material on several shapes) is compared once.
    if !seen.insert(Rc::as_ptr(a) as usize) {
        return true;
    }
    for (pa, pb) in a.props.iter().zip(&b.props) {
        if pa.name != pb.name {
            return false;
        }
        if pa.value == pb.value {
            continue;
        }
        let Some(key) = loaded.object_keys.get(&(Rc::as_ptr(a) as usize)) else {
            return false;
        };
        let found = [
            format!("{key}.{}", pa.name),
            format!("{key}.{}.value", pa.name),
        ]
        .into_iter()
        .find_map(|k| params.get(&k).map(|p| (k, p)));
        let Some((k, p)) = found else { return false };
        let Some(v) = param_value(&pb.value, &p.kind) else {
            return false;
        };
        out.push((k, v));
    }
    a.children.iter().zip(&b.children).all(|(ca, cb)| {
        ca.name == cb.name && diff(&ca.object, &cb.object, loaded, params, out, seen)
    })
}

/// A described value as the parameter of `kind` takes it.
fn param_value(
    v: &Value,
    kind: &yubin_core::params::ParamKind,
) -> Option<yubin_core::params::ParamValue> {
    use yubin_core::params::{ParamKind as K, ParamValue as P};
    Some(match (v, kind) {
        (Value::Float(f), K::Float) => P::Float(*f as f32),
        (Value::Integer(i), K::Float) => P::Float(*i as f32),
        (Value::Integer(i), K::Integer) => P::Integer(*i),
        (Value::Boolean(b), K::Boolean) => P::Boolean(*b),
        (Value::String(s), K::String) => P::String(s.clone()),
        (Value::Point(p) | Value::Vector(p), K::Point | K::Vector) => P::Vector(*p),
        (Value::Transform(m), K::Transform) => P::Transform(*m),
        (Value::Rgb(c), K::Color(_)) => P::Color(yubin_core::Rgb::from(*c)),
        (Value::Float(f), K::Color(_)) => P::Color(yubin_core::Rgb::splat(*f as f32)),
        _ => return None,
    })
}
