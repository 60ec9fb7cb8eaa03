#!/usr/bin/env python3
"""Generates crates/yubin-core/src/spectrum/ior_table.rs, the RGB complex
indices of refraction (eta, k) of the named conductors that `conductor` and
`roughconductor` accept as `material="..."`, from measured spectra.

Usage:
    scripts/gen-ior-table.py [IOR_DIR] > crates/yubin-core/src/spectrum/ior_table.rs

IOR_DIR (default: ../shared/mitsuba-data/ior beside the repository, i.e.
/work/shared/mitsuba-data/ior) holds pairs NAME.eta.spd and NAME.k.spd: the
real and imaginary parts of the index, one "wavelength_nm value" pair a line,
'#' starting a comment. Every complete pair becomes one row of the table.
Plain Python 3; no third-party packages.

The conversion reproduces what Mitsuba 3's RGB variants use for
`material="Au"` (checked against Mitsuba 3.9.1, scalar_rgb, through
`mi.traverse` on a loaded conductor: all materials agree to 1e-5): the
spectrum is treated as an *unweighted* quantity, with no D65 illuminant
(unlike spectra written inline for `eta`, which Mitsuba weights by D65):

    XYZ = sum_i cmf(l_i) * s(l_i) / sum_i ybar(l_i)
    RGB = max(0, M_sRGB * XYZ)

over the 1000 evenly spaced wavelengths l_i from 360 to 830 nm (both ends
included), where cmf are the CIE 1931 2-degree matching functions tabulated
at 5 nm and interpolated linearly, s is the measured spectrum interpolated
linearly between its samples and zero outside them, and M_sRGB is the XYZ to
linear sRGB matrix of IEC 61966-2-1. No clamping above: an index of
refraction is not bounded by one. The matching functions are read from
crates/yubin-core/src/spectrum/cie.rs, the table the renderer uses for the
same conversion at run time (spectrum::spectrum_fn_to_rgb), so the two cannot
drift apart.
"""

import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
CIE_RS = os.path.join(ROOT, "crates", "yubin-core", "src", "spectrum", "cie.rs")
DEFAULT_IOR_DIR = os.path.join(os.path.dirname(ROOT), "shared", "mitsuba-data", "ior")

CIE_MIN, CIE_MAX, CIE_STEP, STEPS = 360.0, 830.0, 5.0, 1000

# IEC 61966-2-1, XYZ to linear sRGB (D65 white).
XYZ_TO_SRGB = (
    (3.240479, -1.537150, -0.498535),
    (-0.969256, 1.875992, 0.041556),
    (0.055648, -0.204043, 1.057311),
)


def read_cmf():
    """The rows of CIE1931_XYZ in cie.rs: [x, y, z], // wavelength."""
    text = open(CIE_RS, encoding="utf-8").read()
    block = text[text.index("BEGIN CIE1931_XYZ"):text.index("END CIE1931_XYZ")]
    rows = re.findall(r"\[([^\]]+)\],\s*//\s*(\d+)", block)
    cmf = []
    for i, (values, wavelength) in enumerate(rows):
        if float(wavelength) != CIE_MIN + CIE_STEP * i:
            sys.exit(f"{CIE_RS}: row {i} is for {wavelength} nm")
        cmf.append(tuple(float(v) for v in values.split(",")))
    if len(cmf) != int((CIE_MAX - CIE_MIN) / CIE_STEP) + 1:
        sys.exit(f"{CIE_RS}: expected 95 rows of CIE1931_XYZ, found {len(cmf)}")
    return cmf


def cmf_at(cmf, wavelength):
    x = (wavelength - CIE_MIN) / CIE_STEP
    i = min(int(x), len(cmf) - 2)
    t = x - i
    return [cmf[i][c] + t * (cmf[i + 1][c] - cmf[i][c]) for c in range(3)]


def read_spd(path):
    samples = []
    for n, line in enumerate(open(path, encoding="utf-8"), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = line.split()
        if len(fields) != 2:
            sys.exit(f"{path}:{n}: expected 'wavelength value', got {line!r}")
        samples.append((float(fields[0]), float(fields[1])))
    if len(samples) < 2 or any(a[0] >= b[0] for a, b in zip(samples, samples[1:])):
        sys.exit(f"{path}: needs at least two samples with increasing wavelengths")
    return samples


def interpolate(samples, wavelength):
    if wavelength < samples[0][0] or wavelength > samples[-1][0]:
        return None
    lo, hi = 0, len(samples) - 1
    while hi - lo > 1:  # bisection for the interval holding the wavelength
        mid = (lo + hi) // 2
        if samples[mid][0] <= wavelength:
            lo = mid
        else:
            hi = mid
    (l0, v0), (l1, v1) = samples[lo], samples[hi]
    return v0 + (wavelength - l0) / (l1 - l0) * (v1 - v0)


def to_rgb(cmf, samples):
    acc, y_sum = [0.0, 0.0, 0.0], 0.0
    for i in range(STEPS):
        wavelength = CIE_MIN + (CIE_MAX - CIE_MIN) * i / (STEPS - 1)
        xyz = cmf_at(cmf, wavelength)
        y_sum += xyz[1]
        v = interpolate(samples, wavelength)
        if v is not None:
            for c in range(3):
                acc[c] += xyz[c] * v
    xyz = [a / y_sum for a in acc]
    return [max(0.0, sum(m * v for m, v in zip(row, xyz))) for row in XYZ_TO_SRGB]


def rust_f32(v):
    s = f"{v:.6}"
    return s if any(ch in s for ch in ".e") else s + ".0"


def main():
    ior_dir = sys.argv[1] if len(sys.argv) > 1 else DEFAULT_IOR_DIR
    cmf = read_cmf()
    names = sorted(
        f[: -len(".eta.spd")]
        for f in os.listdir(ior_dir)
        if f.endswith(".eta.spd") and os.path.exists(os.path.join(ior_dir, f[: -len(".eta.spd")] + ".k.spd"))
    )
    if not names:
        sys.exit(f"{ior_dir}: no NAME.eta.spd / NAME.k.spd pairs")
    out = [
        "//! GENERATED by `scripts/gen-ior-table.py` (do not edit): the RGB complex",
        f"//! IORs of the {len(names)} conductors measured in Mitsuba 3's data set",
        "//! (`mitsuba-data/ior/NAME.{eta,k}.spd`, from the luxpop.com and Palik",
        "//! databases), converted as Mitsuba 3's RGB variants do for",
        "//! `material=\"NAME\"` (the script's docstring says how). Regenerate with",
        "//! `scripts/gen-ior-table.py [IOR_DIR] > crates/yubin-core/src/spectrum/ior_table.rs`.",
        "",
        "/// (name, eta, k), sorted by name.",
        "#[rustfmt::skip]",
        "pub(super) const CONDUCTORS: &[(&str, [f32; 3], [f32; 3])] = &[",
    ]
    for name in names:
        eta = to_rgb(cmf, read_spd(os.path.join(ior_dir, name + ".eta.spd")))
        k = to_rgb(cmf, read_spd(os.path.join(ior_dir, name + ".k.spd")))
        out.append(
            f'    ("{name}", [{", ".join(map(rust_f32, eta))}], [{", ".join(map(rust_f32, k))}]),'
        )
    out.append("];")
    print("\n".join(out))


if __name__ == "__main__":
    main()
