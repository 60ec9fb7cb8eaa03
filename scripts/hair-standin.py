#!/usr/bin/env python3
"""Writes a stand-in for `material_hair.m3hair`, the hair model Mitsuba's documentation scenes
`bsdf_hair_blonde.xml` and `bsdf_hair_brown.xml` read (too large for Mitsuba's repository, and
not in ../shared), so that both renderers can render those scenes as written:

    python3 scripts/hair-standin.py out/hair-standin/material_hair.m3hair
    scripts/docs-parity --path out/hair-standin \\
        ../shared/mitsuba-data/docs/scenes/bsdf_hair_blonde.xml ../shared/mitsuba-data/docs/scenes/bsdf_hair_brown.xml

The file is Mitsuba's curve text format (a control point `x y z radius` per line, a blank line
between strands): 1500 wavy B-spline strands falling from a crown over the scenes' floor, in the
scenes' object space (their `to_world` maps it where their camera looks). Deterministic.
"""
import math
import os
import random
import sys


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def rotation(axis, degrees):
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    m = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    m[i][i], m[i][j], m[j][i], m[j][j] = c, -s, s, c
    return m


def inverse_rigid_scaled(m):
    """Inverse of scale * rotation * translation (an orthogonal 3x3 part times a uniform scale)."""
    scale2 = sum(m[0][k] ** 2 for k in range(3))
    r_inv = [[m[j][i] / scale2 for j in range(3)] for i in range(3)]
    t = [m[i][3] for i in range(3)]
    out = [r_inv[i] + [-sum(r_inv[i][k] * t[k] for k in range(3))] for i in range(3)]
    return out + [[0.0, 0.0, 0.0, 1.0]]


def apply(m, p):
    return [sum(m[i][k] * p[k] for k in range(3)) + m[i][3] for i in range(3)]


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "out/hair-standin/material_hair.m3hair"
    # The scenes' to_world, composed as Mitsuba composes it (each step left-multiplied).
    to_world = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    translate = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    translate[1][3] = -10.0
    scale = [[0.36 if i == j and i < 3 else (1.0 if i == j else 0.0) for j in range(4)] for i in range(4)]
    for step in [translate, rotation("z", 133), rotation("y", 84), rotation("x", -48), scale]:
        to_world = mat_mul(step, to_world)
    to_object = inverse_rigid_scaled(to_world)
    world_scale = 0.36
    rng = random.Random(7)
    strands = []
    for _ in range(1500):
        # Roots on a crown (a cap of radius 0.45 around (0, 0, 1.25), world space, z up).
        a = rng.uniform(0, 2 * math.pi)
        r = 0.45 * math.sqrt(rng.uniform(0, 1))
        root = [r * math.cos(a), r * math.sin(a), 1.25 + 0.3 * math.sqrt(max(0.0, 1 - (r / 0.45) ** 2))]
        outward = [math.cos(a), math.sin(a)]
        length = rng.uniform(1.1, 1.6)
        wave, phase = rng.uniform(0.03, 0.07), rng.uniform(0, 2 * math.pi)
        points = []
        n = 12
        for k in range(n):
            s = k / (n - 1)
            # Out and down: a fountain that falls onto the floor (z = 0) and does not go through it.
            spread = (0.2 + r) * (1.0 + 1.4 * s)
            x = outward[0] * spread + wave * math.sin(9 * s + phase)
            y = outward[1] * spread + wave * math.cos(7 * s + phase)
            z = max(0.03, root[2] - length * s * s * 1.1)
            radius = 0.004 * (1.0 - 0.6 * s)
            p = apply(to_object, [x, y, z])
            points.append((p, radius / world_scale))
        strands.append(points)
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    with open(out, "w") as f:
        for points in strands:
            for p, radius in points:
                f.write(f"{p[0]:.6f} {p[1]:.6f} {p[2]:.6f} {radius:.6f}\n")
            f.write("\n")
    print(f"wrote {out}: {len(strands)} strands")


if __name__ == "__main__":
    main()
