#!/usr/bin/env python3
"""Cached Mitsuba 3 references (per-pixel mean and per-sample variance) and
the per-pixel Z-test of a yubin render against them. See scripts/README.md.

Run through `scripts/mitsuba-ref reference ...` / `scripts/mitsuba-ref ztest ...`
(the venv's python, with mitsuba 3.9.1 and numpy).

Reference (`reference`)
  K runs (seeds 0..K-1) of N spp each, variant scalar_rgb, with Mitsuba's
  `moment` integrator wrapped around the scene's own integrator (built with
  mi.load_dict({"type": "moment", "nested": scene.integrator()}), so the scene
  file is not edited). Per run the film gives m1 = E[f] and m2 = E[f^2] per
  pixel (filter-weighted, in CIE XYZ); the runs are averaged, then
    REF_mean.exr = XYZ->RGB(m1)                 (linear sRGB, float32)
    REF_var.exr  = XYZ->RGB(m2 - m1^2)          per-SAMPLE variance, not of the mean
  exactly the layout of the `*_ref_rgb.exr` / `*_ref_rgb_var.exr` files of
  Mitsuba's test_renders.py (the RGB variance can have small negative entries;
  the Z-test converts it back to XYZ, where it is >= 0 up to rounding).
  Files go to the cache (default <repo>/.cache/mitsuba-refs/), named
  <scene stem>-<key>_{mean,var}.exr plus <...>.json with the metadata; the key
  is a SHA-256 over the scene file, every file it includes or names
  (<include>, <string name="filename">), the -D values, spp, runs, resolution,
  --strip-legacy, variant and the Mitsuba version.

Z-test (`ztest`)
  The method of crates/yubin-core/src/testing/ztest.rs (Mitsuba's
  test_renders.py), replicated here in numpy: everything converted to XYZ with
  the same matrix, z = |mean - ref| * sqrt(spp / max(var, 1e-4)) per pixel and
  channel, p = erfc(z / sqrt 2) (the same Numerical-Recipes erfc as ztest.rs),
  alpha = 1 - 0.99^(1/pixels) (Sidak over pixels), a channel test fails when
  p <= alpha, and the image passes when >= 99.75 % of the 3*pixels tests pass.
  spp = the yubin render's spp (default floor(2e6 / pixels), as in the
  _shared Mitsuba tests).

--res WxH (or --res N: longest side N, aspect kept, rounded) renders a
temporary copy of the scene (and of every file it includes) in which the
<film>'s width/height are replaced; <path> values and includes are made
absolute and the scene's own folder is added as a <path>, so relative file
names keep resolving, for Mitsuba and yubin alike.
"""

import argparse
import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

SCRIPT_DIR = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(SCRIPT_DIR)
TOOL_VERSION = "mitsuba-parity-1"  # bump when the reference recipe changes
DEFAULT_CACHE = os.path.join(REPO, ".cache", "mitsuba-refs")

# --- Z-test constants: the same as crates/yubin-core/src/testing/ztest.rs ---
VARIANCE_FLOOR = 1e-4
PASS_FRACTION = 0.9975
SIGNIFICANCE = 0.01
# Linear sRGB -> CIE XYZ (D65), the matrix of ztest.rs (= Mitsuba's srgb_to_xyz).
SRGB_TO_XYZ = [
    [0.412453, 0.357580, 0.180423],
    [0.212671, 0.715160, 0.072169],
    [0.019334, 0.119193, 0.950227],
]

sys.path.insert(0, SCRIPT_DIR)
from mitsuba_render import strip_legacy as strip_legacy_text  # noqa: E402


class ToolError(Exception):
    pass


# ----------------------------------------------------------------------------
# Scene files: includes, referenced files, film size, temporary copies
# ----------------------------------------------------------------------------

def parse_defines(defs):
    out = {}
    for d in defs or []:
        if "=" not in d:
            raise ToolError(f"-D expects name=value, got {d!r}")
        k, v = d.split("=", 1)
        out[k.strip()] = v
    return out


class SceneFiles:
    """Walks a scene file and its includes (recursively), the way yubin's and
    Mitsuba's parsers look files up: the main scene's folder, then the <path>
    folders (relative to the file declaring them); includes also next to the
    including file. `$name` is substituted from -D, then <default>s."""

    def __init__(self, scene_path, defines):
        self.main = os.path.abspath(scene_path)
        self.defines = dict(defines)
        self.defaults = {}
        self.search = [os.path.dirname(self.main)]
        self.files = []          # (path, ElementTree) in visit order
        self.referenced = []     # (name as written, resolved path or None)
        self.film = None         # (file index, <film> element)
        self._visit(self.main, [])

    def subst(self, s):
        def rep(m):
            k = m.group(1)
            if k in self.defines:
                return self.defines[k]
            return self.defaults.get(k, m.group(0))
        return re.sub(r"\$([A-Za-z_]\w*)", rep, s)

    def resolve(self, name, own_dir=None):
        name = self.subst(name)
        if os.path.isabs(name):
            return name if os.path.exists(name) else None
        dirs = list(self.search)
        if own_dir and own_dir not in dirs:
            dirs.append(own_dir)
        for d in dirs:
            p = os.path.join(d, name)
            if os.path.exists(p):
                return os.path.normpath(p)
        return None

    def search_dir(self, value, here):
        """The folder a <path value=> names: as Mitsuba's file resolver
        does, a relative value is looked up in the search folders so far
        (the main scene's first), then next to the declaring file."""
        value = self.subst(value)
        for d in [*self.search, here]:
            p = os.path.normpath(os.path.join(d, value))
            if os.path.isdir(p):
                return p
        return os.path.normpath(os.path.join(here, value))

    def _visit(self, path, stack):
        if path in stack:
            raise ToolError(f"include cycle at {path}")
        try:
            tree = ET.parse(path)
        except (ET.ParseError, OSError) as e:
            raise ToolError(f"cannot parse {path}: {e}")
        idx = len(self.files)
        self.files.append((path, tree))
        here = os.path.dirname(path)
        for el in tree.getroot().iter():
            tag = el.tag
            if tag == "default" and "name" in el.attrib:
                self.defaults.setdefault(el.get("name"), el.get("value", ""))
            elif tag == "path" and "value" in el.attrib:
                d = self.search_dir(el.get("value"), here)
                if d not in self.search:
                    self.search.append(d)
            elif tag == "include" and "filename" in el.attrib:
                p = self.resolve(el.get("filename"), here)
                if p is None:
                    self.referenced.append((el.get("filename"), None))
                else:
                    self._visit(p, stack + [path])
            elif tag == "string" and el.get("name") == "filename" and "value" in el.attrib:
                self.referenced.append((el.get("value"), self.resolve(el.get("value"), here)))
            elif tag == "film" and self.film is None:
                # (file index, position in iter() order, element)
                pos = list(tree.getroot().iter()).index(el)
                self.film = (idx, pos, el)

    def film_size(self):
        """(width, height) of the first <film>, Mitsuba's default 768x576."""
        w, h = 768, 576
        if self.film is not None:
            for c in self.film[2]:
                if c.tag == "integer" and c.get("name") in ("width", "height"):
                    try:
                        v = int(self.subst(c.get("value", "")))
                    except ValueError:
                        raise ToolError(f"cannot read film {c.get('name')}={c.get('value')!r}")
                    if c.get("name") == "width":
                        w = v
                    else:
                        h = v
        return w, h

    def content_digest(self):
        """SHA-256 over every file (XML and referenced data), in visit order."""
        h = hashlib.sha256()
        for path, _ in self.files:
            h.update(b"xml\0" + os.path.basename(path).encode() + b"\0")
            with open(path, "rb") as f:
                h.update(hashlib.sha256(f.read()).digest())
        for name, p in self.referenced:
            h.update(b"ref\0" + name.encode() + b"\0")
            if p is None or not os.path.isfile(p):
                h.update(b"missing")
            else:
                fh = hashlib.sha256()
                with open(p, "rb") as f:
                    for chunk in iter(lambda: f.read(1 << 20), b""):
                        fh.update(chunk)
                h.update(fh.digest())
        return h.hexdigest()


def parse_res(res, native):
    """--res 'WxH' or 'N' (longest side N, aspect of `native` kept)."""
    if res is None:
        return None
    m = re.fullmatch(r"(\d+)[xX](\d+)", res)
    if m:
        return int(m.group(1)), int(m.group(2))
    if res.isdigit():
        n = int(res)
        w, h = native
        if w >= h:
            return n, max(1, round(n * h / w))
        return max(1, round(n * w / h)), n
    raise ToolError(f"--res expects WxH or N, got {res!r}")


def _sub_outside_comments(pattern, repl, text, count=0):
    """re.sub that leaves matches starting inside <!-- ... --> alone."""
    comments = [(m.start(), m.end()) for m in re.finditer(r"<!--.*?-->", text, re.S)]
    out, pos, done = [], 0, 0
    for m in re.finditer(pattern, text, re.S):
        if any(a <= m.start() < b for a, b in comments):
            continue
        if count and done >= count:
            break
        out.append(text[pos:m.start()])
        out.append(repl(m))
        pos = m.end()
        done += 1
    out.append(text[pos:])
    return "".join(out)


def write_copy(files, tmpdir, size, strip_legacy, extra_paths=()):
    """Writes the scene and its includes into tmpdir with the film resized
    (when `size`), legacy parameters stripped (when asked), <path> values and
    includes absolute, and the scene's own folder and `extra_paths` added as
    <path>s. The
    edits are textual and keep every line where it was, so that error
    messages' line numbers hold for the original files. Returns the path of
    the main copy and a {copy: original} map."""
    copies = {}
    for i, (path, _) in enumerate(files.files):
        copies[path] = os.path.join(tmpdir, f"{i:02d}_{os.path.basename(path)}")
    attr = r'"([^"]*)"'
    for i, (path, tree) in enumerate(files.files):
        with open(path, encoding="utf-8") as f:
            text = f.read()
        here = os.path.dirname(path)

        def abs_path(m):
            v = m.group(2)
            if "$" not in v:
                v = files.search_dir(v, here)
            return f'{m.group(1)}"{v}"'
        text = _sub_outside_comments(r"(<path\s+value\s*=\s*)" + attr, abs_path, text)

        def include(m):
            p = files.resolve(m.group(2), here)
            return f'{m.group(1)}"{copies.get(p, p or m.group(2))}"'
        text = _sub_outside_comments(r"(<include\s+filename\s*=\s*)" + attr, include, text)

        if size is not None and files.film is not None and files.film[0] == i:
            def film(m):
                body = m.group(0)
                if body.endswith("/>") and "</film>" not in body:  # <film .../>
                    body = body[:-2].rstrip() + "></film>"
                for name, v in (("width", size[0]), ("height", size[1])):
                    pat = r'<integer\b(?=[^>]*\bname\s*=\s*"' + name + r'")[^>]*>'
                    body, n = re.subn(pat, lambda mm: re.sub(
                        r'(\bvalue\s*=\s*)"[^"]*"', lambda vv: f'{vv.group(1)}"{v}"', mm.group(0)),
                        body)
                    if n == 0:
                        body = re.sub(r"^(<film\b[^>]*>)",
                                      lambda mm: mm.group(1) + f'<integer name="{name}" value="{v}"/>',
                                      body)
                return body
            text = _sub_outside_comments(r"<film\b[^>]*?(?:/>|>.*?</film>)", film, text, count=1)

        if strip_legacy:
            text, _ = strip_legacy_text(text)
        if i == 0:
            paths = "".join(f'<path value="{p}"/>'
                            for p in [os.path.dirname(path), *map(os.path.abspath, extra_paths)])
            text = _sub_outside_comments(
                r"(<scene\b[^>]*>)", lambda m: m.group(1) + paths, text, count=1)
        with open(copies[path], "w", encoding="utf-8") as f:
            f.write(text)
    return copies[files.files[0][0]], {v: k for k, v in copies.items()}


class PreparedScene:
    """The scene to load (the original, or a temporary copy), its size and
    the cache key inputs."""

    def __init__(self, args):
        self.args = args
        self.defines = parse_defines(args.defines)
        self.files = SceneFiles(args.scene, self.defines)
        self.native = self.files.film_size()
        self.size = parse_res(args.res, self.native) or self.native
        self.tmpdir = None
        self.path = self.files.main
        self.originals = {}
        if args.res is not None or args.strip_legacy or args.paths:
            self.tmpdir = tempfile.mkdtemp(prefix="mitsuba-parity-")
            self.path, self.originals = write_copy(self.files, self.tmpdir,
                                   self.size if args.res is not None else None,
                                   args.strip_legacy, args.paths)

    def unmap(self, text):
        """Names the original files in a message about the temporary copies."""
        for copy, orig in self.originals.items():
            text = text.replace(copy, orig)
        return text

    def cleanup(self):
        if self.tmpdir:
            shutil.rmtree(self.tmpdir, ignore_errors=True)

    def key(self, mitsuba_version):
        spec = {
            "tool": TOOL_VERSION,
            "mitsuba": mitsuba_version,
            "variant": "scalar_rgb",
            "content": self.files.content_digest(),
            "defines": sorted(self.defines.items()),
            "spp": self.args.spp,
            "runs": self.args.runs,
            "res": list(self.size) if self.args.res is not None else None,
            "strip_legacy": bool(self.args.strip_legacy),
            "paths": [os.path.abspath(p) for p in self.args.paths],
        }
        return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest(), spec


# ----------------------------------------------------------------------------
# Mitsuba reference
# ----------------------------------------------------------------------------

def mitsuba():
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    return mi


def ref_paths(args, prep):
    mi = mitsuba()
    key, spec = prep.key(mi.__version__)
    stem = os.path.splitext(os.path.basename(prep.files.main))[0]
    base = os.path.join(os.path.abspath(args.cache), f"{stem}-{key[:16]}")
    return base, key, spec


def render_reference(args, prep, base, key, spec):
    mi = mitsuba()
    import numpy as np
    if args.threads:
        import drjit as dr
        dr.set_thread_count(args.threads)
    fr = mi.file_resolver() if hasattr(mi, "file_resolver") else mi.Thread.thread().file_resolver()
    fr.prepend(os.path.dirname(prep.files.main))
    t0 = time.perf_counter()
    scene = mi.load_file(prep.path, **prep.defines)
    moment = mi.load_dict({"type": "moment", "nested": scene.integrator()})
    film = scene.sensors()[0].film()
    size = tuple(int(v) for v in film.size())
    if size != tuple(prep.size):
        raise ToolError(f"Mitsuba's film is {size[0]}x{size[1]}, expected "
                        f"{prep.size[0]}x{prep.size[1]}")
    m1 = m2 = None
    run_means = []
    for run in range(args.runs):
        mi.render(scene, integrator=moment, spp=args.spp, seed=run)
        parts = dict(film.bitmap(raw=False).split())
        a = np.array(parts["nested"], dtype=np.float64)
        b = np.array(parts["m2_nested"], dtype=np.float64)
        run_means.append(a)
        m1 = a if m1 is None else m1 + a
        m2 = b if m2 is None else m2 + b
        print(f"  run {run + 1}/{args.runs}: seed {run}, {args.spp} spp "
              f"({time.perf_counter() - t0:.1f} s)", flush=True)
    m1 /= args.runs
    m2 /= args.runs
    var = m2 - m1 * m1
    elapsed = time.perf_counter() - t0

    def to_rgb(xyz):
        return np.array(mi.Bitmap(xyz.astype(np.float32), mi.Bitmap.PixelFormat.XYZ).convert(
            mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False))

    os.makedirs(os.path.dirname(base), exist_ok=True)
    for suffix, img in (("_mean.exr", to_rgb(m1)), ("_var.exr", to_rgb(var))):
        tmp = base + suffix + ".tmp"
        mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(tmp, mi.Bitmap.FileFormat.OpenEXR)
        os.replace(tmp, base + suffix)
    meta = dict(spec)
    meta.update({
        "key": key,
        "scene": prep.files.main,
        "size": list(size),
        "total_spp": args.spp * args.runs,
        "seeds": list(range(args.runs)),
        "integrator": str(scene.integrator()).split("[")[0],
        "render_seconds": round(elapsed, 2),
        "variance": "per-sample (m2 - m1^2 of the moment integrator), XYZ->RGB",
        "command": " ".join(["scripts/mitsuba-ref"] + sys.argv[1:]),
    })
    # Diagnostic: the spread of the per-run means says how the filter changes
    # the variance of a pixel mean compared to var/spp (about 1 for a box
    # filter, < 1 for filters that spread each sample over several pixels:
    # the Z-test is then conservative by that factor).
    if args.runs >= 2:
        rm = np.stack(run_means)
        emp = rm.var(axis=0, ddof=1) * args.spp  # per-sample equivalent, XYZ
        ok = var > 1e-6
        if np.any(ok):
            meta["runs_variance_ratio_mean"] = float(np.mean(emp[ok] / var[ok]))
    with open(base + ".json", "w") as f:
        json.dump(meta, f, indent=1)
    print(f"reference: {base}_mean.exr, {base}_var.exr ({size[0]}x{size[1]}, "
          f"{args.runs} x {args.spp} spp, {elapsed:.1f} s)")


def get_reference(args, prep):
    base, key, spec = ref_paths(args, prep)
    if args.force or not (os.path.exists(base + "_mean.exr") and os.path.exists(base + "_var.exr")):
        print(f"rendering Mitsuba reference for {prep.files.main} (key {key[:16]})", flush=True)
        render_reference(args, prep, base, key, spec)
    else:
        print(f"cached reference: {base}_{{mean,var}}.exr")
    if getattr(args, "out", None):
        os.makedirs(os.path.dirname(os.path.abspath(args.out)) or ".", exist_ok=True)
        for suffix in ("_mean.exr", "_var.exr"):
            shutil.copyfile(base + suffix, args.out + suffix)
        print(f"copied to {args.out}_mean.exr, {args.out}_var.exr")
    return base


# ----------------------------------------------------------------------------
# Z-test (replicates crates/yubin-core/src/testing/ztest.rs)
# ----------------------------------------------------------------------------

def erfc_nr(x):
    """Numerical Recipes' erfc (Chebyshev fit, fractional error < 1.2e-7),
    the one ztest.rs uses."""
    import numpy as np
    z = np.abs(x)
    t = 1.0 / (1.0 + 0.5 * z)
    poly = -z * z - 1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (
        -0.18628806 + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (
            -0.82215223 + t * 0.17087277))))))))
    r = t * np.exp(poly)
    return np.where(x >= 0.0, r, 2.0 - r)


def to_xyz(rgb):
    import numpy as np
    return rgb.astype(np.float64) @ np.array(SRGB_TO_XYZ).T


def z_test(mean, spp, ref, ref_var, alpha=SIGNIFICANCE):
    """mean, ref, ref_var: HxWx3 linear sRGB. Returns a dict like ZTestReport."""
    import numpy as np
    m, r, v = to_xyz(mean), to_xyz(ref), to_xyz(ref_var)
    v = np.maximum(v, VARIANCE_FLOOR)
    with np.errstate(invalid="ignore", over="ignore"):
        z = np.abs(m - r) * np.sqrt(spp / v)
        p = np.where(np.isfinite(z), erfc_nr(np.where(np.isfinite(z), z, 0.0) / math.sqrt(2.0)), 0.0)
    n = p.size
    pixels = max(n // 3, 1)
    alpha_c = 1.0 - (1.0 - alpha) ** (1.0 / pixels)
    fail = p <= alpha_c
    failures = int(np.count_nonzero(fail))
    return {
        "passed": bool(n > 0 and (n - failures) >= PASS_FRACTION * n),
        "failures": failures,
        "count": int(n),
        "pixels_outside": int(np.count_nonzero(fail.any(axis=-1))),
        "alpha_corrected": alpha_c,
        "min_p": float(p.min()) if n else 1.0,
        "max_z": float(np.nanmax(np.where(np.isfinite(z), z, np.inf))) if n else 0.0,
        "z": z,
    }


def z_threshold(alpha_c):
    """z at which erfc(z/sqrt2) = alpha_c (bisection on the same erfc)."""
    lo, hi = 0.0, 40.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if float(erfc_nr(mid / math.sqrt(2.0))) > alpha_c:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def write_z_png(path, z, zt):
    """False colour of max_channel z: black (0) -> blue -> green (zt/2) ->
    yellow (zt) -> red (>= 2 zt); NaN magenta."""
    import numpy as np
    mi = mitsuba()
    zz = np.nanmax(np.where(np.isfinite(z), z, np.nan), axis=-1) / zt
    stops = np.array([0.0, 0.25, 0.5, 1.0, 2.0])
    cols = np.array([[0, 0, 0], [0, 0, 1], [0, 1, 0], [1, 1, 0], [1, 0, 0]], dtype=np.float64)
    x = np.clip(np.nan_to_num(zz, nan=0.0), 0.0, 2.0)
    img = np.stack([np.interp(x, stops, cols[:, c]) for c in range(3)], axis=-1)
    img[np.isnan(zz)] = [1, 0, 1]
    img8 = (img * 255 + 0.5).astype(np.uint8)
    mi.Bitmap(img8, mi.Bitmap.PixelFormat.RGB).write(path)


def read_rgb(path):
    import numpy as np
    mi = mitsuba()
    bmp = mi.Bitmap(path)
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    arr = np.array(bmp, dtype=np.float32)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    try:
        idx = [names.index(c) for c in ("R", "G", "B")]
    except ValueError:
        idx = [0, 1, 2] if arr.shape[-1] >= 3 else [0, 0, 0]
    return arr[:, :, idx]


def first_error_line(text):
    lines = [l.strip() for l in text.splitlines() if l.strip()]
    for l in lines:
        if "rror" in l:
            return l
    return lines[-1] if lines else "(no output)"


def cmd_ztest(args):
    import numpy as np
    prep = PreparedScene(args)
    result = {"scene": prep.files.main, "size": list(prep.size)}
    # yubin may render another file than the reference's (to show that a
    # difference is Mitsuba's: see --yubin-scene).
    yprep = prep
    if args.yubin_scene:
        yprep = PreparedScene(argparse.Namespace(**{**vars(args), "scene": args.yubin_scene}))
        result["yubin_scene"] = yprep.files.main
    try:
        w, h = prep.size
        spp = args.yubin_spp or max(1, 2_000_000 // (w * h))
        result["yubin_spp"] = spp
        yubin = args.yubin or os.path.join(REPO, "target", "release", "yubin")
        if not os.path.exists(yubin) and os.path.exists("/work/main/target/release/yubin"):
            yubin = "/work/main/target/release/yubin"
        out_dir = tempfile.mkdtemp(prefix="yubin-ztest-")
        out = os.path.join(out_dir, "yubin.exr")
        cmd = [yubin, "render", yprep.path, "-o", out, "--spp", str(spp),
               "--seed", str(args.yubin_seed), "-q"]
        for k, v in prep.defines.items():
            cmd += ["-D", f"{k}={v}"]
        if args.threads:
            cmd += ["--threads", str(args.threads)]
        # yubin first: when it cannot load the scene, no reference is needed.
        print(f"yubin: {' '.join(cmd)}", flush=True)
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        result["yubin_seconds"] = round(time.perf_counter() - t0, 2)
        if proc.returncode != 0 or not os.path.exists(out):
            shutil.rmtree(out_dir, ignore_errors=True)
            msg = yprep.unmap(first_error_line(proc.stderr + "\n" + proc.stdout))
            result.update(status="yubin-error", message=msg)
            print(f"yubin cannot load/render: {msg}")
            return 2, result
        img = read_rgb(out)
        shutil.rmtree(out_dir, ignore_errors=True)
        try:
            base = get_reference(args, prep)
        except Exception as e:  # Mitsuba failed to load/render
            msg = prep.unmap(first_error_line(str(e))) if str(e) else type(e).__name__
            result.update(status="mitsuba-error", message=msg)
            print(f"Mitsuba failed: {msg}")
            return 2, result
        ref, var = read_rgb(base + "_mean.exr"), read_rgb(base + "_var.exr")
        if img.shape != ref.shape:
            result.update(status="size-mismatch",
                          message=f"yubin {img.shape[1]}x{img.shape[0]} vs reference "
                                  f"{ref.shape[1]}x{ref.shape[0]}")
            print(result["message"])
            return 2, result
        rep = z_test(img, spp, ref, var)
        zt = z_threshold(rep["alpha_corrected"])
        lum = np.array([0.2126, 0.7152, 0.0722])
        lr = float((ref @ lum).mean())
        bias = float((img @ lum).mean()) / lr - 1.0 if lr > 0 else float("nan")
        brighter = z_test(img * 1.03, spp, ref, var)
        result.update(
            status="pass" if rep["passed"] else "fail",
            failures=rep["failures"], count=rep["count"],
            pixels_outside=rep["pixels_outside"], pixels=w * h,
            alpha_corrected=rep["alpha_corrected"], z_threshold=zt,
            max_z=rep["max_z"], min_p=rep["min_p"], luminance_bias=bias,
            brighter_3pct_fails=not brighter["passed"], reference=base)
        print(f"Z-test ({w}x{h}, yubin {spp} spp, seed {args.yubin_seed}) against {base}_*.exr")
        print(f"  Sidak-corrected alpha = {rep['alpha_corrected']:.4g} (|z| > {zt:.3f} fails)")
        print(f"  channel tests failed: {rep['failures']} / {rep['count']} "
              f"(allowed {int((1 - PASS_FRACTION) * rep['count'])}); "
              f"pixels outside: {rep['pixels_outside']} / {w * h}")
        print(f"  max |z| = {rep['max_z']:.3f}, min p = {rep['min_p']:.3g}, "
              f"mean-luminance bias {100 * bias:+.3f} %")
        # Informative only (not part of pass/fail): the image-mean difference
        # per channel against its standard deviation, treating pixels as
        # independent with the reference's variance / spp. Small global biases
        # that no single pixel reveals show up here (exact for a box filter;
        # wider filters make var/spp too large but correlate neighbours).
        d = (to_xyz(img) - to_xyz(ref)).reshape(-1, 3)
        v = np.maximum(to_xyz(var), VARIANCE_FLOOR).reshape(-1, 3)
        zmean = d.sum(axis=0) / np.sqrt(v.sum(axis=0) / spp)
        result["image_mean_z_xyz"] = [float(x) for x in zmean]
        print(f"  image-mean z (X, Y, Z; informative, pixels taken as independent): "
              f"{zmean[0]:+.2f} {zmean[1]:+.2f} {zmean[2]:+.2f}")
        print(f"  sensitivity: a 3 % brighter image {'fails' if not brighter['passed'] else 'PASSES (weak test)'}"
              f" ({brighter['failures']} channel tests fail)")
        if args.z_png:
            write_z_png(args.z_png, rep["z"], zt)
            print(f"  z image: {args.z_png}")
        print("PASS" if rep["passed"] else "FAIL")
        return (0 if rep["passed"] else 1), result
    finally:
        prep.cleanup()


def cmd_reference(args):
    prep = PreparedScene(args)
    try:
        get_reference(args, prep)
    except ToolError:
        raise
    except Exception as e:  # Mitsuba failed to load/render
        print(f"Mitsuba failed: {prep.unmap(first_error_line(str(e)) or type(e).__name__)}",
              file=sys.stderr)
        return 2
    finally:
        prep.cleanup()
    return 0


def add_common(ap):
    ap.add_argument("scene", help="Mitsuba 3 scene XML file")
    ap.add_argument("--runs", type=int, default=4, help="reference runs, seeds 0..K-1 (default 4)")
    ap.add_argument("--spp", type=int, default=2048, help="reference spp per run (default 2048)")
    ap.add_argument("-D", dest="defines", action="append", metavar="NAME=VALUE",
                    help="scene parameter (both renderers); repeatable")
    ap.add_argument("--res", default=None,
                    help="film size WxH, or N = longest side N keeping the aspect")
    ap.add_argument("--strip-legacy", action="store_true",
                    help="drop <integer name=light_samples> / <string name=file_format> "
                         "(see mitsuba-ref render)")
    ap.add_argument("--cache", default=os.environ.get("MITSUBA_REF_CACHE", DEFAULT_CACHE),
                    help="cache folder (default <repo>/.cache/mitsuba-refs, or $MITSUBA_REF_CACHE)")
    ap.add_argument("--force", action="store_true", help="re-render even when cached")
    ap.add_argument("--path", dest="paths", action="append", default=[], metavar="DIR",
                    help="an extra search path for both renderers (repeatable), e.g. where "
                         "a docs scene's meshes really are")
    ap.add_argument("--threads", type=int, default=None, help="threads for Mitsuba and yubin")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("reference", help="make (or find) the cached reference")
    add_common(r)
    r.add_argument("--out", default=None, help="also copy to OUT_mean.exr / OUT_var.exr")
    z = sub.add_parser("ztest", help="Z-test a yubin render against the reference")
    add_common(z)
    z.add_argument("--yubin", default=None, help="yubin binary (default target/release/yubin)")
    z.add_argument("--yubin-spp", type=int, default=None,
                   help="yubin spp (default floor(2e6 / pixels), as in the _shared tests)")
    z.add_argument("--yubin-seed", type=int, default=0)
    z.add_argument("--yubin-scene", default=None, metavar="FILE",
                   help="yubin renders FILE instead of the reference's scene (same size and "
                        "search paths), e.g. to compare against a Mitsuba workaround of a Mitsuba bug")
    z.add_argument("--z-png", default=None, help="write a false-colour PNG of max-channel |z|")
    z.add_argument("--json", default=None, help="write the result as JSON")
    args = ap.parse_args()
    try:
        if args.cmd == "reference":
            sys.exit(cmd_reference(args))
        code, result = cmd_ztest(args)
    except ToolError as e:
        print(f"error: {e}", file=sys.stderr)
        code, result = 2, {"scene": args.scene, "status": "tool-error", "message": str(e)}
        if args.cmd == "reference":
            sys.exit(2)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1, default=str)
    sys.exit(code)


if __name__ == "__main__":
    main()
