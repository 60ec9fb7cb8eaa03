#!/usr/bin/env python3
"""Blender Cycles reference renders of named test cases (run by scripts/cycles-ref).

  cycles_render.py cases
  cycles_render.py render CASE -o OUT.exr [--spp N] [--res N] [--seed S] [--threads N]
                          [-P name=value]... [--mask MASK.exr] [--verbose]
  cycles_render.py compare A.exr REF.exr [--mask-from M.exr]

Each case is built in bpy from factory settings with an empty scene, rendered
with Cycles on the CPU and written as a linear float32 EXR with plain R, G, B
channels. scripts/cycles-cases/CASE.xml is the same scene for yubin / Mitsuba 3
(its <default>s carry the same parameter names, so `-P roughness=0.5` here is
`-D roughness=0.5` there). See scripts/README.md and scripts/REFERENCE-NOTES.md.
"""
import argparse
import math
import os
import struct
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CASES_DIR = os.path.join(HERE, "cycles-cases")


# --------------------------------------------------------------------------
# Cases. Each has default parameters (overridable with -P name=value), a
# builder that fills the empty bpy scene, and an optional analytic value.

def _sphere_env_defaults():
    return {"reflectance": 0.8, "radiance": 1.0, "sphere": "points"}


CASES = {
    "diffuse_sphere_env": {
        "doc": "unit sphere at the origin, Lambertian (Diffuse BSDF roughness 0), "
               "uniform white environment; camera (0,0,4) -> origin, fov 30 deg",
        "params": dict(_sphere_env_defaults()),
    },
    "roughdiffuse_sphere_env": {
        "doc": "as diffuse_sphere_env with Diffuse BSDF roughness R (Cycles 4.2: "
               "Fujii's improved qualitative Oren-Nayar, sigma = clamp(R, 0, 1))",
        "params": dict(_sphere_env_defaults(), roughness=0.5),
    },
    "difftrans_slab_sun": {
        "doc": "8x8 square in the z=0 plane (normal +z, seen from +z), Translucent BSDF "
               "T, lit from behind (-z side) by a Sun of irradiance E, angle 0, "
               "tilted theta degrees from the normal; black world",
        "params": {"transmittance": 0.6, "irradiance": math.pi, "theta": 30.0},
    },
}


def parse_params(case, overrides):
    params = dict(CASES[case]["params"])
    for item in overrides:
        if "=" not in item:
            raise SystemExit(f"-P expects name=value, got '{item}'")
        k, v = item.split("=", 1)
        if k not in params:
            raise SystemExit(f"case {case} has no parameter '{k}' "
                             f"(has: {', '.join(sorted(params))})")
        params[k] = type(params[k])(v) if not isinstance(params[k], str) else v
    return params


def fujii_on_albedo(mu_o, sigma, n_theta=256, n_phi=256):
    """Directional albedo (per unit reflectance) of Fujii's improved qualitative
    Oren-Nayar BRDF f = rho (A + B s/t), A = 1/(pi + (pi/2 - 2/3) sigma),
    B = sigma A, s = l.v - (n.l)(n.v), t = max(n.l, n.v) if s > 0 else 1
    (sigma = 0 is Lambert), by midpoint quadrature over the hemisphere."""
    import numpy as np
    A = 1.0 / (math.pi + (math.pi / 2 - 2.0 / 3.0) * sigma)
    B = sigma * A
    th = (np.arange(n_theta) + 0.5) * (math.pi / 2) / n_theta
    ph = (np.arange(n_phi) + 0.5) * (2 * math.pi) / n_phi
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    li = np.stack([np.sin(TH) * np.cos(PH), np.sin(TH) * np.sin(PH), np.cos(TH)], -1)
    dw = np.sin(TH) * (math.pi / 2 / n_theta) * (2 * math.pi / n_phi)
    out = []
    for mu in np.atleast_1d(mu_o):
        v = np.array([math.sqrt(max(0.0, 1 - mu * mu)), 0.0, mu])
        nl, nv = li[..., 2], mu
        s = li @ v - nl * nv
        t = np.where(s > 0, np.maximum(nl, nv), 1.0)
        f = A + B * s / t
        out.append(float((f * nl * dw).sum()))
    return np.array(out)


def sphere_env_prediction(p, roughness, res, fov_deg=30.0, sub=8):
    """Expected image of the sphere_env cases (unit sphere, camera (0,0,4), box
    filter): a convex object in a uniform environment L only ever sees L, so a
    point's radiance is rho L times the BRDF's directional albedo at its view
    angle. Returns (image, covered) with covered = fraction of each pixel's
    area on the sphere."""
    import numpy as np
    sigma = min(max(roughness, 0.0), 1.0)
    mus = np.linspace(0.0, 1.0, 65)
    alb = fujii_on_albedo(mus, sigma)
    tan_h = math.tan(math.radians(fov_deg) / 2)
    o = np.array([0.0, 0.0, 4.0])
    img = np.zeros((res, res))
    cov = np.zeros((res, res))
    u = (np.arange(res * sub) + 0.5) / (res * sub)            # left -> right, top -> bottom
    X, Y = np.meshgrid((2 * u - 1) * tan_h, (1 - 2 * u) * tan_h)
    d = np.stack([X, Y, -np.ones_like(X)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    b = d @ o
    disc = b * b - (o @ o - 1.0)
    hit = disc > 0
    tt = -b - np.sqrt(np.where(hit, disc, 0.0))
    n = o + tt[..., None] * d
    mu = np.clip(-(n * d).sum(-1), 0.0, 1.0)
    L = p["radiance"]
    val = np.where(hit, p["reflectance"] * L * np.interp(mu, mus, alb), L)
    img = val.reshape(res, sub, res, sub).mean(axis=(1, 3))
    cov = hit.reshape(res, sub, res, sub).mean(axis=(1, 3))
    return img, cov


def analytic(case, p):
    """(description, value) of a closed-form pixel value, or None."""
    if case == "diffuse_sphere_env":
        # Convex Lambertian object in a uniform environment L: every bounce sees
        # the environment, so the sphere's radiance is rho * L exactly.
        return ("sphere radiance rho*L (background L)", p["reflectance"] * p["radiance"])
    if case == "difftrans_slab_sun":
        v = p["transmittance"] * p["irradiance"] * math.cos(math.radians(p["theta"])) / math.pi
        return ("front radiance T*E*cos(theta)/pi", v)
    return None


# --------------------------------------------------------------------------
# Scene construction (bpy)

def common_settings(bpy, scene, args):
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = args.spp
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.use_preview_denoising = False
    cy.seed = args.seed
    cy.use_animated_seed = False
    # Pixel filter: box of width 1 px = uniform samples over the pixel, no
    # sharing between pixels (Mitsuba's / yubin's <rfilter type="box"/>).
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    # Bounces: Cycles' maximum everywhere (Mitsuba's path max_depth = -1).
    for attr in ("max_bounces", "diffuse_bounces", "glossy_bounces",
                 "transmission_bounces", "volume_bounces", "transparent_max_bounces"):
        setattr(cy, attr, 1024)
    # No clamping, no caustics filtering, no light-threshold culling, no
    # approximations.
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.light_sampling_threshold = 0.0
    cy.use_fast_gi = False
    if hasattr(cy, "use_guiding"):
        cy.use_guiding = False
    cy.film_exposure = 1.0
    scene.render.film_transparent = False
    # Colour management: Standard view, no look, exposure 0, gamma 1. EXR output
    # is scene-linear anyway (the view transform only applies to display /
    # 8-bit outputs), this just makes the settings explicit.
    scene.display_settings.display_device = "sRGB"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.view_settings.use_curve_mapping = False
    scene.render.dither_intensity = 0.0
    # Resolution
    scene.render.resolution_x = args.res
    scene.render.resolution_y = args.res
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = 1.0
    scene.render.pixel_aspect_y = 1.0
    scene.render.use_border = False
    scene.render.use_persistent_data = False
    if args.threads:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = args.threads
    else:
        scene.render.threads_mode = "AUTO"
    # Output: single-part OpenEXR, float32, RGB (channels R, G, B).
    im = scene.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    scene.render.use_file_extension = False
    scene.render.use_compositing = False
    scene.render.use_sequencer = False


def add_camera(bpy, scene, origin=(0.0, 0.0, 4.0), fov_deg=30.0):
    """Perspective camera at origin looking at (0,0,0) with +y up; fov_deg is the
    horizontal field of view (Mitsuba's default fov_axis="x")."""
    from mathutils import Vector
    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "PERSP"
    cam_data.lens_unit = "FOV"
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.angle = math.radians(fov_deg)
    cam_data.shift_x = cam_data.shift_y = 0.0
    cam_data.clip_start = 0.01    # Mitsuba near_clip / far_clip defaults
    cam_data.clip_end = 10000.0
    cam_data.dof.use_dof = False
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = Vector(origin)
    # Blender cameras look down their local -Z with local +Y up.
    d = Vector((0.0, 0.0, 0.0)) - Vector(origin)
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = d.to_track_quat("-Z", "Y")
    scene.camera = cam
    return cam


def set_world(bpy, scene, rgb, strength):
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    nt = world.node_tree
    nt.nodes.clear()
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = (rgb[0], rgb[1], rgb[2], 1.0)
    bg.inputs["Strength"].default_value = strength
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    scene.world = world
    return world


def make_material(bpy, name, bsdf_type, inputs):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    bsdf = nt.nodes.new(bsdf_type)
    for k, v in inputs.items():
        bsdf.inputs[k].default_value = v
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.target = "CYCLES"
    nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    mat.cycles.displacement_method = "BUMP"
    return mat


def add_sphere(bpy, scene, mat, mode):
    """Unit sphere at the origin. mode 'points': a one-point point cloud made by
    geometry nodes, which Cycles intersects as an exact sphere (true silhouette
    and normals, like Mitsuba's analytic sphere). mode 'mesh': a smooth-shaded
    UV sphere of 512 x 256 segments."""
    if mode == "mesh":
        import bmesh
        me = bpy.data.meshes.new("sphere")
        bm = bmesh.new()
        bmesh.ops.create_uvsphere(bm, u_segments=512, v_segments=256, radius=1.0)
        bm.to_mesh(me)
        bm.free()
        for poly in me.polygons:
            poly.use_smooth = True
        me.materials.append(mat)
        obj = bpy.data.objects.new("sphere", me)
        obj.cycles.shadow_terminator_geometry_offset = 0.0
        obj.cycles.shadow_terminator_offset = 0.0
        scene.collection.objects.link(obj)
        return obj
    if mode != "points":
        raise SystemExit(f"sphere={mode}: expected 'points' or 'mesh'")
    me = bpy.data.meshes.new("anchor")
    me.from_pydata([(0.0, 0.0, 0.0)], [], [])
    obj = bpy.data.objects.new("sphere", me)
    scene.collection.objects.link(obj)
    ng = bpy.data.node_groups.new("unit_sphere_point", "GeometryNodeTree")
    ng.interface.new_socket(name="Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket(name="Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    n_in = ng.nodes.new("NodeGroupInput")
    n_out = ng.nodes.new("NodeGroupOutput")
    to_pts = ng.nodes.new("GeometryNodeMeshToPoints")
    to_pts.mode = "VERTICES"
    to_pts.inputs["Radius"].default_value = 1.0
    set_mat = ng.nodes.new("GeometryNodeSetMaterial")
    set_mat.inputs["Material"].default_value = mat
    ng.links.new(n_in.outputs[0], to_pts.inputs["Mesh"])
    ng.links.new(to_pts.outputs["Points"], set_mat.inputs["Geometry"])
    ng.links.new(set_mat.outputs["Geometry"], n_out.inputs[0])
    mod = obj.modifiers.new("unit_sphere", "NODES")
    mod.node_group = ng
    return obj


def build_sphere_env(bpy, scene, p, roughness):
    add_camera(bpy, scene)
    L = p["radiance"]
    set_world(bpy, scene, (1.0, 1.0, 1.0), L)
    rho = p["reflectance"]
    mat = make_material(bpy, "diffuse", "ShaderNodeBsdfDiffuse",
                        {"Color": (rho, rho, rho, 1.0), "Roughness": roughness})
    add_sphere(bpy, scene, mat, p["sphere"])


def build_difftrans_slab_sun(bpy, scene, p):
    from mathutils import Vector
    add_camera(bpy, scene)
    set_world(bpy, scene, (0.0, 0.0, 0.0), 0.0)
    T = p["transmittance"]
    mat = make_material(bpy, "translucent", "ShaderNodeBsdfTranslucent",
                        {"Color": (T, T, T, 1.0)})
    s = 4.0
    me = bpy.data.meshes.new("slab")
    me.from_pydata([(-s, -s, 0.0), (s, -s, 0.0), (s, s, 0.0), (-s, s, 0.0)], [],
                   [(0, 1, 2, 3)])   # counter-clockwise seen from +z: normal +z
    me.materials.append(mat)
    obj = bpy.data.objects.new("slab", me)
    scene.collection.objects.link(obj)
    # Sun: light travels along `direction` (from the -z side through the slab
    # towards +z), theta from the slab normal. Blender lights emit along their
    # local -Z.
    th = math.radians(p["theta"])
    direction = Vector((math.sin(th), 0.0, math.cos(th)))
    sun_data = bpy.data.lights.new("sun", "SUN")
    sun_data.energy = p["irradiance"]      # W/m^2 = irradiance on a surface facing the sun
    sun_data.angle = 0.0
    sun_data.color = (1.0, 1.0, 1.0)
    sun = bpy.data.objects.new("sun", sun_data)
    sun.rotation_mode = "QUATERNION"
    sun.rotation_quaternion = direction.to_track_quat("-Z", "Y")
    sun.location = -4.0 * direction
    scene.collection.objects.link(sun)


def build(bpy, case, p):
    scene = bpy.context.scene
    if case == "diffuse_sphere_env":
        build_sphere_env(bpy, scene, p, 0.0)
    elif case == "roughdiffuse_sphere_env":
        build_sphere_env(bpy, scene, p, p["roughness"])
    elif case == "difftrans_slab_sun":
        build_difftrans_slab_sun(bpy, scene, p)
    else:
        raise SystemExit(f"unknown case '{case}'")
    return scene


# --------------------------------------------------------------------------
# EXR helpers

def exr_channels(path):
    """Channel names in an OpenEXR file's header (single part)."""
    with open(path, "rb") as f:
        data = f.read(1 << 16)
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError(f"{path}: not an OpenEXR file")
    pos = 8
    while True:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        if not name:
            break
        pos = end + 1
        end = data.index(b"\0", pos)
        typ = data[pos:end].decode()
        pos = end + 1
        (size,) = struct.unpack("<i", data[pos:pos + 4])
        pos += 4
        value = data[pos:pos + size]
        pos += size
        if name == "channels" and typ == "chlist":
            names, q = [], 0
            while value[q] != 0:
                e = value.index(b"\0", q)
                names.append(value[q:e].decode())
                q = e + 1 + 16
            return names
    return []


def read_exr(path):
    """H x W x 3 float64 array (top row first) of an EXR, read through bpy's
    image loader as scene-linear data (no colour transform)."""
    import bpy
    import numpy as np
    img = bpy.data.images.load(os.path.abspath(path), check_existing=False)
    try:
        img.colorspace_settings.name = "Non-Color"   # raw values
        w, h = img.size
        px = np.empty(w * h * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
        a = px.reshape(h, w, 4)[::-1, :, :3].astype(np.float64)
    finally:
        bpy.data.images.remove(img)
    return a


def load_compare_module():
    import importlib.util
    spec = importlib.util.spec_from_file_location("yubin_compare", os.path.join(HERE, "compare.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# --------------------------------------------------------------------------
# Commands

def cmd_cases(_argv):
    for name, c in CASES.items():
        ps = ", ".join(f"{k}={v:g}" if not isinstance(v, str) else f"{k}={v}"
                       for k, v in c["params"].items())
        print(f"{name}\n    {c['doc']}\n    params: {ps}\n    xml: scripts/cycles-cases/{name}.xml")


def render_once(bpy, case, p, args, out, transparent=False, spp=None):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    common_settings(bpy, scene, args)
    build(bpy, case, p)
    if transparent:
        scene.render.film_transparent = True
        scene.render.image_settings.color_mode = "RGBA"
    if spp is not None:
        scene.cycles.samples = spp
    tmp = out + ".tmp.exr"
    scene.render.filepath = tmp
    t0 = time.time()
    # Blender prints a progress line per sample batch on stdout: silence it at
    # the file-descriptor level unless --verbose.
    sys.stdout.flush()
    saved = None
    if not getattr(args, "verbose", False):
        saved = os.dup(1)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.close(devnull)
    try:
        bpy.ops.render.render(write_still=True)
    finally:
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)
    dt = time.time() - t0
    if not os.path.exists(tmp):
        raise SystemExit(f"Cycles wrote no file at {tmp}")
    return tmp, dt


def cmd_render(argv):
    ap = argparse.ArgumentParser(prog="cycles-ref render")
    ap.add_argument("case", choices=sorted(CASES))
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=0, help="0 = all cores")
    ap.add_argument("-P", dest="params", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--verbose", action="store_true", help="show Blender's progress output")
    ap.add_argument("--mask", help="also write a coverage mask EXR (R=G=B=alpha of a "
                    "film_transparent render, 16 spp): 1 where the objects cover the pixel")
    args = ap.parse_args(argv)
    p = parse_params(args.case, args.params)
    out = os.path.abspath(args.output)
    os.makedirs(os.path.dirname(out) or ".", exist_ok=True)

    import bpy
    print(f"cycles-ref: Blender {bpy.app.version_string}, case {args.case}, "
          f"{args.res}x{args.res}, {args.spp} spp, seed {args.seed}, params {p}", flush=True)
    tmp, dt = render_once(bpy, args.case, p, args, out)
    chans = exr_channels(tmp)
    if sorted(chans) != ["B", "G", "R"]:
        raise SystemExit(f"unexpected EXR channels {chans} in {tmp}")
    os.replace(tmp, out)
    print(f"render time: {dt:.2f} s")
    print(f"wrote {out} (channels {','.join(chans)}, float32, scene-linear Rec.709)")

    a = read_exr(out)
    w = [0.2126, 0.7152, 0.0722]
    lum = a @ w
    print(f"mean lum {lum.mean():.6g}; centre 8x8 mean RGB "
          f"{[round(float(x), 6) for x in a[a.shape[0]//2-4:a.shape[0]//2+4, a.shape[1]//2-4:a.shape[1]//2+4].reshape(-1, 3).mean(0)]}")
    an = analytic(args.case, p)
    if an is not None:
        desc, val = an
        if args.case == "difftrans_slab_sun":
            m = float(a.mean())
            print(f"analytic {desc} = {val:.6g}; image mean {m:.6g} "
                  f"({(m - val) / val:+.4%}); min {a.min():.6g} max {a.max():.6g}")
        else:
            print(f"analytic {desc} = {val:.6g}")

    if args.case in ("diffuse_sphere_env", "roughdiffuse_sphere_env"):
        rough = p.get("roughness", 0.0)
        pred, cov = sphere_env_prediction(p, rough, args.res)
        full = cov >= 1.0
        lum_full = float((a @ w)[full].mean())
        print(f"prediction (Fujii ON, sigma={min(max(rough, 0), 1):g}; sigma 0 = Lambert): "
              f"mean over {int(full.sum())} fully covered pixels {pred[full].mean():.6g}, "
              f"Cycles {lum_full:.6g} ({(lum_full - pred[full].mean()) / pred[full].mean():+.4%}); "
              f"whole image {pred.mean():.6g}, Cycles {float(lum.mean()):.6g} "
              f"({(float(lum.mean()) - pred.mean()) / pred.mean():+.4%})")
        # Radial bands of the disc (by pixel-centre distance over the silhouette
        # radius): the rough models differ most towards the limb.
        import numpy as np
        res = args.res
        c = (np.arange(res) + 0.5) / res * 2 - 1
        rr = np.hypot(*np.meshgrid(c, c)) / (math.tan(math.asin(0.25)) / math.tan(math.radians(15)))
        bands = []
        for lo, hi in ((0, 0.5), (0.5, 0.8), (0.8, 0.95), (0.95, 1.0)):
            m = full & (rr >= lo) & (rr < hi)
            if m.any():
                pm, cm = pred[m].mean(), float((a @ w)[m].mean())
                bands.append(f"r {lo:g}-{hi:g}: {pm:.5f} vs {cm:.5f} ({(cm - pm) / pm:+.3%})")
        print("  prediction vs Cycles by band: " + "; ".join(bands))

    if args.mask:
        mask_out = os.path.abspath(args.mask)
        tmp, _ = render_once(bpy, args.case, p, args, mask_out, transparent=True, spp=16)
        import numpy as np
        img = bpy.data.images.load(tmp, check_existing=False)
        img.colorspace_settings.name = "Non-Color"
        wd, ht = img.size
        px = np.empty(wd * ht * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
        alpha = px.reshape(-1, 4)[:, 3].copy()
        bpy.data.images.remove(img)
        os.remove(tmp)
        write_exr_rgb(bpy, mask_out, np.repeat(alpha[:, None], 3, axis=1), wd, ht)
        print(f"wrote mask {mask_out} ({int((alpha >= 0.999).sum())} fully covered pixels)")


def write_exr_rgb(bpy, path, rgb_bottom_up, w, h):
    """Write an RGB float32 EXR (rows bottom-up, Blender's pixel order)."""
    import numpy as np
    img = bpy.data.images.new("out", width=w, height=h, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    px = np.ones((w * h, 4), dtype=np.float32)
    px[:, :3] = rgb_bottom_up
    img.pixels.foreach_set(px.ravel())
    scene = bpy.context.scene
    im = scene.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    tmp = path + ".tmp.exr"
    img.save_render(tmp, scene=scene)
    bpy.data.images.remove(img)
    os.replace(tmp, path)


def cmd_compare(argv):
    ap = argparse.ArgumentParser(prog="cycles-ref compare")
    ap.add_argument("a")
    ap.add_argument("ref")
    ap.add_argument("--mask-from", help="EXR whose first channel >= 0.999 selects the "
                    "pixels for a second, masked comparison (e.g. render --mask)")
    args = ap.parse_args(argv)
    import numpy as np
    cmp = load_compare_module()
    a, b = read_exr(args.a), read_exr(args.ref)
    for path in (args.a, args.ref):
        ch = exr_channels(path)
        if ch[:3] != ["B", "G", "R"] and sorted(ch) != ["B", "G", "R"]:
            print(f"note: {path} has channels {ch}; using the first three read")

    def report(tag, r, n):
        print(f"[{tag}] pixels {n}")
        print(f"  relMSE: {r['relMSE']:.6g}")
        print(f"  RMSE:   {r['RMSE']:.6g}")
        print(f"  mean lum A = {r['lum_A']:.6g}, REF = {r['lum_REF']:.6g}, bias = {r['bias']:+.4%}")
        if r["nonfinite_A"]:
            print(f"  WARNING: {r['nonfinite_A']} non-finite values in A")

    print(f"A:   {args.a}\nREF: {args.ref}\nsize: {a.shape[1]}x{a.shape[0]}")
    report("all", cmp.compare(a, b), a.shape[0] * a.shape[1])
    if args.mask_from:
        m = read_exr(args.mask_from)[..., 0] >= 0.999
        if m.shape != a.shape[:2]:
            raise SystemExit(f"mask size {m.shape} differs from {a.shape[:2]}")
        report("mask", cmp.compare(a[m][None], b[m][None]), int(m.sum()))
        report("outside mask", cmp.compare(a[~m][None], b[~m][None]), int((~m).sum()))


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    cmd, argv = sys.argv[1], sys.argv[2:]
    if cmd == "cases":
        cmd_cases(argv)
    elif cmd == "render":
        cmd_render(argv)
    elif cmd == "compare":
        cmd_compare(argv)
    else:
        print(__doc__, file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
