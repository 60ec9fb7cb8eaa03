#!/usr/bin/env python3
"""Compare two linear RGB EXR images: compare.py A.exr REF.exr

Prints (over the first 3 channels of both images, which must be the same size):
  relMSE = mean over pixels and channels of (a-b)^2 / (b^2 + 0.01)
  RMSE   = sqrt(mean over pixels and channels of (a-b)^2)
  bias   = (mean lum A - mean lum REF) / mean lum REF,
           lum = 0.2126 R + 0.7152 G + 0.0722 B
EXR files are read with Mitsuba's Bitmap (from .venv-mitsuba; this script
re-executes itself with that venv's python if mitsuba is not importable), or
with the `OpenEXR` / `imageio` packages if those are installed instead.
"""
import os
import sys


def _reexec_in_venv():
    here = os.path.dirname(os.path.abspath(__file__))
    venv = os.environ.get("MITSUBA_VENV", os.path.join(here, "..", ".venv-mitsuba"))
    py = os.path.join(venv, "bin", "python")
    in_venv = os.path.realpath(sys.prefix) == os.path.realpath(venv)
    if os.path.exists(py) and not in_venv and not os.environ.get("_COMPARE_REEXEC"):
        os.environ["_COMPARE_REEXEC"] = "1"
        os.execv(py, [py, os.path.abspath(__file__)] + sys.argv[1:])


def read_exr(path):
    import numpy as np
    try:
        import mitsuba as mi
        mi.set_variant("scalar_rgb")
        bmp = mi.Bitmap(path)
        bmp = bmp.convert(bmp.pixel_format(), mi.Struct.Type.Float32, False)
        a = np.array(bmp, copy=True)
    except ImportError:
        try:
            import OpenEXR, Imath  # noqa: E401
            f = OpenEXR.InputFile(path)
            dw = f.header()["dataWindow"]
            w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
            pt = Imath.PixelType(Imath.PixelType.FLOAT)
            a = np.stack([np.frombuffer(f.channel(c, pt), np.float32).reshape(h, w)
                          for c in "RGB"], axis=-1)
        except ImportError:
            import imageio.v3 as iio
            a = np.asarray(iio.imread(path), dtype=np.float32)
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[-1] == 1:
        a = np.repeat(a, 3, axis=-1)
    return a[..., :3].astype(np.float64)


def compare(a, b):
    import numpy as np
    if a.shape != b.shape:
        raise SystemExit(f"size mismatch: {a.shape} vs {b.shape}")
    d = a - b
    relmse = float(np.mean(d * d / (b * b + 0.01)))
    rmse = float(np.sqrt(np.mean(d * d)))
    w = np.array([0.2126, 0.7152, 0.0722])
    la, lb = float((a @ w).mean()), float((b @ w).mean())
    return {"relMSE": relmse, "RMSE": rmse, "lum_A": la, "lum_REF": lb,
            "bias": (la - lb) / lb if lb != 0 else float("nan"),
            "nonfinite_A": int((~np.isfinite(a)).sum())}


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        _reexec_in_venv()
    a, b = read_exr(sys.argv[1]), read_exr(sys.argv[2])
    r = compare(a, b)
    print(f"A:   {sys.argv[1]}")
    print(f"REF: {sys.argv[2]}")
    print(f"size:   {a.shape[1]}x{a.shape[0]}")
    print(f"relMSE: {r['relMSE']:.6g}")
    print(f"RMSE:   {r['RMSE']:.6g}")
    print(f"mean lum A = {r['lum_A']:.6g}, REF = {r['lum_REF']:.6g}, "
          f"bias = {r['bias']:+.4%}")
    if r["nonfinite_A"]:
        print(f"WARNING: {r['nonfinite_A']} non-finite values in A")


if __name__ == "__main__":
    main()
