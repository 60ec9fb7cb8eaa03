//! The Blender path: a scene made in Blender, exported by Blender's own
//! glTF exporter (`scripts/blender-to-gltf`), renders in yubin with its
//! camera, light and material. Skips, saying why, where Blender is not
//! installed.

use std::path::Path;
use std::process::Command;
use yubin_core::render::{render, RenderSettings};
use yubin_scene::gltf::{load_gltf, GltfOptions};

/// Builds the scene in Blender: a red cube at the origin, a point light
/// above it, a camera looking at it; saves it as a .blend.
const MAKE_SCENE: &str = r#"
import bpy, sys
out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_cube_add(size=2, location=(0, 0, 0))
cube = bpy.context.active_object
mat = bpy.data.materials.new("red")
mat.use_nodes = True
bsdf = mat.node_tree.nodes["Principled BSDF"]
bsdf.inputs["Base Color"].default_value = (0.8, 0.05, 0.05, 1)
bsdf.inputs["Roughness"].default_value = 0.6
cube.data.materials.append(mat)
light = bpy.data.lights.new("lamp", type="POINT")
light.energy = 2000
lamp = bpy.data.objects.new("lamp", light)
lamp.location = (3, -4, 6)
bpy.context.collection.objects.link(lamp)
cam_data = bpy.data.cameras.new("cam")
cam = bpy.data.objects.new("cam", cam_data)
cam.location = (6, -6, 4)
bpy.context.collection.objects.link(cam)
track = cam.constraints.new(type="TRACK_TO")
track.target = cube
track.track_axis = "TRACK_NEGATIVE_Z"
track.up_axis = "UP_Y"
bpy.context.view_layer.update()
cam.matrix_world = cam.matrix_world.copy()
cam.constraints.remove(track)
bpy.context.scene.camera = cam
bpy.context.scene.render.resolution_x = 64
bpy.context.scene.render.resolution_y = 48
bpy.ops.wm.save_as_mainfile(filepath=out)
"#;

#[test]
fn a_blender_scene_exported_to_gltf_renders_with_its_camera_light_and_material() {
    let has_blender = Command::new("blender")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_blender {
        println!("skipped: Blender is not installed (Debian: apt-get install blender)");
        return;
    }
    let exporter_runs = Command::new("blender")
        .args([
            "--background",
            "--factory-startup",
            "--python-exit-code",
            "1",
        ])
        .args(["--python-expr", "import numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !exporter_runs {
        println!(
            "skipped: Blender's glTF exporter needs numpy (Debian: apt-get install python3-numpy)"
        );
        return;
    }
    let dir = std::env::temp_dir().join(format!("yubin-blender-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (blend, glb) = (dir.join("scene.blend"), dir.join("scene.glb"));
    let made = Command::new("blender")
        .args([
            "--background",
            "--factory-startup",
            "--python-expr",
            MAKE_SCENE,
            "--",
        ])
        .arg(&blend)
        .output()
        .unwrap();
    assert!(
        blend.is_file(),
        "Blender made no scene: {}",
        String::from_utf8_lossy(&made.stderr)
    );
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/blender-to-gltf");
    let exported = Command::new(script).arg(&blend).arg(&glb).output().unwrap();
    assert!(
        exported.status.success(),
        "export failed: {}",
        String::from_utf8_lossy(&exported.stderr)
    );
    let options = GltfOptions {
        width: Some(64),
        height: None,
        spp: Some(16),
        env: None,
    };
    let s = load_gltf(&glb, &options).expect("the exported scene loads");
    // The camera's aspect ratio came with it (Blender's 64 × 48), and no
    // environment was added: the point light is the only light.
    assert_eq!((s.scene.film.width, s.scene.film.height), (64, 48));
    let img = render(
        &s.scene,
        s.integrator.as_ref(),
        &RenderSettings { spp: 16, seed: 1 },
        &|_| {},
    )
    .image;
    let px = |x: u32, y: u32| [0, 1, 2].map(|c| img.get(x, y, c));
    // The camera looks at the cube: red in the middle, black in a corner.
    let [r, g, b] = px(32, 24);
    assert!(
        r > 0.02 && r > 3.0 * g && r > 3.0 * b,
        "the middle is {r} {g} {b}, not a lit red cube"
    );
    assert_eq!(
        px(0, 0),
        [0.0; 3],
        "a corner sees something besides the cube"
    );
}
