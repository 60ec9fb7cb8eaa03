#!/usr/bin/env python3
"""Render a Mitsuba 3 scene file to a linear float32 EXR (reference images for yubin).

Run through `scripts/mitsuba-ref render ...`, which sets up the virtual
environment (`.venv-mitsuba`, mitsuba==3.9.1) and the LLVM library for the
`llvm_*` variants. See scripts/README.md.

Outputs
  OUT.exr       the developed film (for a plain RGB film: R,G,B float32, linear).
  OUT_var.exr   only when the scene's integrator is `moment`: the per-sample
                variance m2 - m1^2 of the (first) nested integrator. Mitsuba's
                moment integrator records m1 and m2 in CIE XYZ; the variance is
                computed in XYZ and converted to linear sRGB with Mitsuba's own
                XYZ->RGB conversion, exactly as `src/render/tests/test_renders.py`
                writes its `*_ref_rgb_var.exr` files. In that case OUT.exr holds
                the film's root RGB channels (= the nested integrator's mean).
"""

import argparse
import os
import re
import sys
import tempfile
import time

# Parameters that older Mitsuba scene files carry and Mitsuba 3.9.1 rejects or
# ignores. (tag, name, enclosing plugin tag) -- see --strip-legacy.
LEGACY_PARAMS = [
    # sampler: `light_samples` (Mitsuba 0.x / Tungsten-export leftover; no
    # Mitsuba 3 sampler reads it -> "unreferenced property" error).
    ("integer", "light_samples", "sampler"),
    # film: `file_format` other than openexr/pfm/rgbe ("png" in scene_v3.xml)
    # -> "[HDRFilm] The "file_format" parameter must either be equal to ...".
    # We always write EXR ourselves, so the parameter is dropped whatever its value.
    ("string", "file_format", "film"),
]


def strip_legacy(xml_text):
    """Return (new_text, removed) with the LEGACY_PARAMS elements removed.

    Only self-closing elements `<tag name="NAME" .../>` are removed; the check
    that they sit inside the right plugin is done by tracking the innermost
    open <sampler>/<film>/... element on a simple tag scan.
    """
    removed = []
    out = []
    pos = 0
    stack = []
    tag_re = re.compile(r"<(/?)([A-Za-z_][\w.-]*)([^>]*?)(/?)>", re.S)
    for m in tag_re.finditer(xml_text):
        closing, tag, attrs, selfclose = m.group(1), m.group(2), m.group(3), m.group(4)
        if xml_text.startswith("<!--", m.start()) or xml_text.startswith("<?", m.start()):
            continue
        if closing:
            if stack and stack[-1] == tag:
                stack.pop()
            continue
        drop = False
        if selfclose:
            nm = re.search(r'\bname\s*=\s*"([^"]*)"', attrs)
            for (ltag, lname, parent) in LEGACY_PARAMS:
                if tag == ltag and nm and nm.group(1) == lname and parent in stack[-1:]:
                    drop = True
                    removed.append(f"<{tag} name=\"{lname}\"> in <{parent}> (line "
                                   f"{xml_text.count(chr(10), 0, m.start()) + 1})")
        else:
            stack.append(tag)
        if drop:
            out.append(xml_text[pos:m.start()])
            out.append(f"<!-- stripped by mitsuba_render.py --strip-legacy -->")
            pos = m.end()
    out.append(xml_text[pos:])
    return "".join(out), removed


def parse_defines(defs):
    params = {}
    for d in defs or []:
        if "=" not in d:
            sys.exit(f"error: -D expects name=value, got {d!r}")
        k, v = d.split("=", 1)
        params[k.strip()] = v
    return params


def write_exr_atomic(mi, bmp, path):
    tmp = path + ".tmp"  # `*.exr.tmp` is gitignored
    bmp.write(tmp, mi.Bitmap.FileFormat.OpenEXR)
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="Mitsuba 3 scene XML file")
    ap.add_argument("-o", "--output", required=True, help="output .exr path")
    ap.add_argument("--variant", default="scalar_rgb", help="Mitsuba variant (default scalar_rgb)")
    ap.add_argument("--spp", type=int, default=None,
                    help="samples per pixel: passed as mi.render(scene, spp=N) "
                         "(overrides the sampler's sample_count)")
    ap.add_argument("-D", dest="defines", action="append", metavar="NAME=VALUE",
                    help="scene parameter, passed as mi.load_file(path, NAME=VALUE); repeatable")
    ap.add_argument("--threads", type=int, default=None, help="worker threads (default: all cores)")
    ap.add_argument("--seed", type=int, default=0, help="sampler seed passed to mi.render (default 0)")
    ap.add_argument("--strip-legacy", action="store_true",
                    help="load a temporary copy of the scene without the legacy parameters "
                         "<integer name=\"light_samples\"> (in <sampler>) and "
                         "<string name=\"file_format\"> (in <film>)")
    args = ap.parse_args()

    import mitsuba as mi
    import numpy as np

    mi.set_variant(args.variant)
    if args.threads:
        import drjit as dr
        dr.set_thread_count(args.threads)

    scene_path = os.path.abspath(args.scene)
    scene_dir = os.path.dirname(scene_path)
    # Relative file references (meshes, textures) resolve against the scene's
    # own folder even when we load a temporary copy from elsewhere.
    fr = mi.file_resolver() if hasattr(mi, "file_resolver") else mi.Thread.thread().file_resolver()
    fr.prepend(scene_dir)

    params = parse_defines(args.defines)
    load_path = scene_path
    tmp_scene = None
    if args.strip_legacy:
        with open(scene_path, "r", encoding="utf-8") as f:
            text, removed = strip_legacy(f.read())
        fd, tmp_scene = tempfile.mkstemp(suffix=".xml", prefix="mitsuba-ref-")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        load_path = tmp_scene
        for r in removed:
            print(f"strip-legacy: removed {r}")
        if not removed:
            print("strip-legacy: nothing to remove")

    try:
        t0 = time.perf_counter()
        try:
            scene = mi.load_file(load_path, **params)
        except Exception as e:
            msg = str(e)
            if not args.strip_legacy and ("file_format" in msg or "light_samples" in msg
                                          or "nreferenced" in msg):
                print("hint: the scene has parameters from an older Mitsuba version; "
                      "retry with --strip-legacy", file=sys.stderr)
            raise
        t_load = time.perf_counter() - t0
    finally:
        if tmp_scene:
            os.unlink(tmp_scene)

    # The moment integrator exposes, for each nested integrator NAME, AOVs
    # NAME.X/Y/Z and m2_NAME.X/Y/Z (see src/integrators/moment.cpp).
    is_moment = any(n.startswith("m2_") for n in scene.integrator().aov_names())

    render_kwargs = {"seed": args.seed}
    if args.spp is not None:
        render_kwargs["spp"] = args.spp

    t0 = time.perf_counter()
    img = mi.render(scene, **render_kwargs)
    np.asarray(img)  # force evaluation for JIT (llvm/cuda) variants
    t_render = time.perf_counter() - t0

    film = scene.sensors()[0].film()
    bmp = film.bitmap(raw=False)  # developed, float32, channels named by the film
    size = film.size()
    spp_used = args.spp if args.spp is not None else scene.sensors()[0].sampler().sample_count()

    out = os.path.abspath(args.output)
    os.makedirs(os.path.dirname(out), exist_ok=True)

    if is_moment:
        parts = dict(bmp.split())
        root = parts["<root>"]
        m2_names = sorted(n for n in parts if n.startswith("m2_"))
        if not m2_names:
            sys.exit("error: moment integrator without m2_* AOVs?")
        m2_name = m2_names[0]
        m1_name = m2_name[3:]
        m1 = np.array(parts[m1_name], copy=True)
        m2 = np.array(parts[m2_name], copy=True)
        var_xyz = (m2 - m1 * m1).astype(np.float32)
        var_bmp = mi.Bitmap(var_xyz, mi.Bitmap.PixelFormat.XYZ).convert(
            mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
        root = root.convert(root.pixel_format(), mi.Struct.Type.Float32, False)
        write_exr_atomic(mi, root, out)
        base, ext = os.path.splitext(out)
        var_out = base + "_var" + (ext or ".exr")
        write_exr_atomic(mi, var_bmp, var_out)
        print(f"moment: mean (film root {root.pixel_format()}) -> {out}")
        print(f"moment: per-sample variance m2-m1^2 of '{m1_name}' (XYZ->RGB) -> {var_out}")
    else:
        write_exr_atomic(mi, bmp, out)
        print(f"wrote {out}")

    print(f"variant={args.variant} size={size[0]}x{size[1]} spp={spp_used} "
          f"threads={args.threads or 'all'}")
    print(f"load time:   {t_load:.3f} s")
    print(f"render time: {t_render:.3f} s")


if __name__ == "__main__":
    main()
