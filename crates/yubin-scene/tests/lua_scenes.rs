//! Lua scene scripts: a script and the XML written by hand for the same
//! scene render the same image bit for bit; errors name the script's
//! line; the sandbox refuses running programs, writing files and reading
//! outside the script's directory.

use std::path::{Path, PathBuf};
use yubin_core::render::{render, RenderSettings};
use yubin_scene::lua::{load_lua, LuaOptions};
use yubin_scene::{load_scene_str, LoadedScene};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("yubin-lua-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn image(s: &LoadedScene) -> Vec<f32> {
    render(
        &s.scene,
        s.integrator.as_ref(),
        &RenderSettings { spp: 8, seed: 5 },
        &|_| {},
    )
    .image
    .data
}

/// A red sphere on a grey slab (CS488's unit cube, scaled), a point light
/// and a dim constant environment. Every number is exact in binary, so
/// the order in which transforms are multiplied cannot matter.
const SCRIPT: &str = r#"red = gr.material({albedo = {0.8, 0.2, 0.1}, roughness = 0.4})
grey = gr.material({albedo = gr.const(0.5), roughness = 0.75, metallic = 0})
root = gr.node("root")
ball = gr.sphere("ball")
ball:set_material(red)
ball:translate(0, 1, 0)
root:add_child(ball)
floor = gr.cube("floor")
floor:scale(8, 0.25, 8)
floor:translate(-4, -0.25, -4)
floor:set_material(grey)
root:add_child(floor)
cam = gr.camera{eye = {0, 1, 8}, target = {0, 1, 0}, up = {0, 1, 0}, fov = 40}
gr.render{scene = root, output = "out.png", width = 64, height = 48, spp = 8, camera = cam,
  lights = {gr.light({4, 6, 4}, {60, 60, 60})}, ambient = {0.125, 0.125, 0.125}}
"#;

/// The same scene in Mitsuba XML: the slab is Mitsuba's cube [−1, 1]³
/// moved onto [0, 1]³ first.
const XML: &str = r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <string name="fov_axis" value="y"/>
        <transform name="to_world"><lookat origin="0,1,8" target="0,1,0" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/></film>
        <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
    </sensor>
    <emitter type="point"><point name="position" x="4" y="6" z="4"/><rgb name="intensity" value="60"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.125"/></emitter>
    <shape type="sphere">
        <transform name="to_world"><translate y="1"/></transform>
        <bsdf type="principled"><rgb name="base_color" value="0.8, 0.2, 0.1"/><float name="roughness" value="0.4"/></bsdf>
    </shape>
    <shape type="cube">
        <transform name="to_world">
            <scale value="0.5"/><translate value="0.5"/>
            <scale x="8" y="0.25" z="8"/><translate x="-4" y="-0.25" z="-4"/>
        </transform>
        <bsdf type="principled"><rgb name="base_color" value="0.5"/><float name="roughness" value="0.75"/><float name="metallic" value="0"/></bsdf>
    </shape>
</scene>"#;

#[test]
fn a_script_renders_as_the_same_scene_in_xml() {
    let dir = scratch("same");
    let script = dir.join("scene.lua");
    std::fs::write(&script, SCRIPT).unwrap();
    let (lua, output) = load_lua(&script, &LuaOptions::default()).expect("the script runs");
    assert_eq!(output, Some(PathBuf::from("out.png")));
    let xml = load_scene_str(XML, &dir.join("scene.xml"), &[]).expect("the XML loads");
    let (a, b) = (image(&lua), image(&xml));
    assert!(
        a.iter().any(|&v| v > 0.0),
        "the script's scene renders black"
    );
    assert!(a == b, "the script and the XML render differently");
}

/// The error of running `text` as `scene.lua` in a fresh directory.
fn error_of(name: &str, text: &str) -> String {
    let dir = scratch(name);
    let script = dir.join("scene.lua");
    std::fs::write(&script, text).unwrap();
    match load_lua(&script, &LuaOptions::default()) {
        Ok(_) => panic!("{name}: the script ran"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn errors_name_the_script_and_line() {
    let syntax = error_of("syntax", "x = 1\ny = = 2\n");
    assert!(syntax.contains("scene.lua:2"), "{syntax}");
    let runtime = error_of("runtime", "a = 1\nb = gr.sphere('s')\nb:rotate('q', 10)\n");
    assert!(
        runtime.contains("scene.lua:3") && runtime.contains("axis"),
        "{runtime}"
    );
    let lua_error = error_of("nil", "x = nil\n\nx.y = 3\n");
    assert!(lua_error.contains("scene.lua:3"), "{lua_error}");
    let conversion = error_of("conversion", "n = gr.node('n')\n\nn:translate('a', 2, 3)\n");
    assert!(conversion.contains("scene.lua:3"), "{conversion}");
    let cycle = error_of(
        "cycle",
        "a = gr.node('a')\nb = gr.node('b')\na:add_child(b)\nb:add_child(a)\ngr.render{scene = a}\n",
    );
    assert!(cycle.contains("cycle"), "{cycle}");
    let no_render = error_of("norender", "x = 1\n");
    assert!(no_render.contains("gr.render"), "{no_render}");
}

#[test]
fn the_sandbox_refuses_programs_writes_and_reads_outside() {
    let run = error_of("os", "os.execute('touch /tmp/yubin-lua-pwned')\n");
    assert!(run.contains("scene.lua:1") && run.contains("os"), "{run}");
    assert!(!Path::new("/tmp/yubin-lua-pwned").exists());
    let write = error_of("io", "local f = io.open('written.txt', 'w')\n");
    assert!(
        write.contains("scene.lua:1") && write.contains("io"),
        "{write}"
    );
    let load = error_of("loadfile", "dofile('/etc/passwd')\n");
    assert!(load.contains("scene.lua:1"), "{load}");
    let secret = std::env::temp_dir().join(format!("yubin-lua-secret-{}.png", std::process::id()));
    std::fs::write(&secret, b"not for scripts").unwrap();
    let name = secret.file_name().unwrap().to_string_lossy();
    let outside = error_of("outside", &format!("t = gr.image('../{name}')\n"));
    assert!(
        outside.contains("scene.lua:1") && outside.contains("outside the script's directory"),
        "{outside}"
    );
}

/// The example animation: frames after the first update the scene in
/// place (no rebuild), and each frame renders as the same frame's scene
/// built alone.
#[test]
fn an_animation_updates_in_place_and_each_frame_stands_alone() {
    use yubin_scene::lua::{run_lua_at, LuaAnimation};
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/animation/bounce.lua");
    let mut animation = LuaAnimation::new(&script, LuaOptions::default(), 24.0);
    let mut last = Vec::new();
    for frame in 1..=4 {
        let (loaded, _) = animation.frame(frame).expect("the frame runs");
        let sequence = image(loaded);
        let alone = run_lua_at(&script, &LuaOptions::default(), Some((frame, 24.0))).unwrap();
        let alone = yubin_scene::build::build_scene(&alone.desc).unwrap();
        assert!(
            sequence == image(&alone),
            "frame {frame} differs from its scene built alone"
        );
        assert!(sequence != last, "frame {frame} is the frame before it");
        last = sequence;
    }
    assert_eq!(animation.rebuilds, 1, "frames after the first were rebuilt");
    assert!(animation.updates >= 3 * 3, "{} updates", animation.updates);
}

/// `gr.load` brings a Mitsuba XML scene's shapes and emitters, whose
/// relative files are found beside that XML.
#[test]
fn gr_load_brings_an_xml_scenes_shapes() {
    let dir = scratch("load");
    std::fs::create_dir_all(dir.join("parts")).unwrap();
    std::fs::write(
        dir.join("parts/tri.obj"),
        "v -1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("parts/part.xml"),
        r#"<scene version="3.0.0">
            <shape type="obj"><string name="filename" value="tri.obj"/>
                <emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>
        </scene>"#,
    )
    .unwrap();
    let script = dir.join("scene.lua");
    std::fs::write(
        &script,
        "root = gr.node('root')\nroot:add_child(gr.load('parts/part.xml'))\n\
         gr.render{scene = root, width = 16, height = 16, eye = {0, 0.3, 3}, target = {0, 0.3, 0}}\n",
    )
    .unwrap();
    let (s, _) = load_lua(&script, &LuaOptions::default()).expect("the script loads the part");
    assert_eq!(s.scene.meshes.len(), 1);
    assert!(
        image(&s).iter().any(|&v| v > 0.0),
        "the loaded light is not seen"
    );
}

/// `gr.sdf` and `gr.mandelbox` describe what `<shape type="sdf">` and
/// `<shape type="mandelbox">` do: the same image bit for bit; a bad node
/// is refused at the script's line.
#[test]
fn sdf_shapes_in_lua_render_as_in_xml() {
    let dir = scratch("sdf");
    let script = dir.join("scene.lua");
    let lua_text = r#"grey = gr.material({albedo = gr.const(0.5), roughness = 0.75})
root = gr.node("root")
blob = gr.sdf("blob", {type = "smooth_union", k = 0.25,
  {type = "sphere", radius = 0.75},
  {type = "box", half_size = {0.5, 0.5, 0.5}, rotate = {'y', 45}, translate = {0.75, 0, 0}}},
  {step_factor = 0.875})
blob:set_material(grey)
root:add_child(blob)
fractal = gr.mandelbox("fractal", {scale = -1.5, iterations = 6})
fractal:scale(0.25, 0.25, 0.25)
fractal:translate(-1.5, 0.5, 0)
fractal:set_material(grey)
root:add_child(fractal)
cam = gr.camera{eye = {0, 1, 6}, target = {0, 0, 0}, up = {0, 1, 0}, fov = 40}
gr.render{scene = root, width = 32, height = 24, spp = 8, camera = cam,
  lights = {gr.light({4, 6, 4}, {60, 60, 60})}, ambient = {0.125, 0.125, 0.125}}
"#;
    std::fs::write(&script, lua_text).unwrap();
    let (lua, _) = load_lua(&script, &LuaOptions::default()).expect("the script runs");
    let xml = r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <string name="fov_axis" value="y"/>
        <transform name="to_world"><lookat origin="0,1,6" target="0,0,0" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/></film>
        <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
    </sensor>
    <emitter type="point"><point name="position" x="4" y="6" z="4"/><rgb name="intensity" value="60"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.125"/></emitter>
    <bsdf type="principled" id="grey"><rgb name="base_color" value="0.5"/><float name="roughness" value="0.75"/></bsdf>
    <shape type="sdf">
        <float name="step_factor" value="0.875"/>
        <sdf type="smooth_union"><float name="k" value="0.25"/>
            <sdf type="sphere"><float name="radius" value="0.75"/></sdf>
            <sdf type="box"><vector name="half_size" value="0.5, 0.5, 0.5"/>
                <transform name="to_world"><rotate y="1" angle="45"/><translate x="0.75"/></transform></sdf>
        </sdf>
        <ref id="grey"/>
    </shape>
    <shape type="mandelbox">
        <float name="scale" value="-1.5"/><integer name="iterations" value="6"/>
        <transform name="to_world"><scale value="0.25"/><translate x="-1.5" y="0.5"/></transform>
        <ref id="grey"/>
    </shape>
</scene>"#;
    let xml = load_scene_str(xml, &dir.join("scene.xml"), &[]).expect("the XML loads");
    let (a, b) = (image(&lua), image(&xml));
    assert!(
        a.iter().any(|&v| v > 0.0),
        "the script's scene renders black"
    );
    assert!(a == b, "the script and the XML render differently");
    let bad = error_of(
        "sdfbad",
        "root = gr.node('r')\ns = gr.sdf('s', {type = 'union',\n  {type = 'blob'}, {type = 'sphere'}})\nroot:add_child(s)\ngr.render{scene = root}\n",
    );
    assert!(
        bad.contains("scene.lua:2") && bad.contains("unknown sdf type \"blob\""),
        "{bad}"
    );
}
