#!/usr/bin/env bash
# Denoises a rendered shatter frame with Intel's Open Image Denoise, guided by its denoising
# passes (render.denoising_passes): installs pyoidn (which ships Intel's OIDN library), the
# OpenEXR Python bindings and NumPy into a venv under target/ on first use, then runs
# scripts/denoise.py. The output keeps every other channel and the header.
#
# Usage: scripts/denoise.sh FRAME.exr [OUT.exr]   (default OUT: FRAME.denoised.exr)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
frame="${1:?usage: scripts/denoise.sh FRAME.exr [OUT.exr]}"
out="${2:-${frame%.exr}.denoised.exr}"
[ -f "$frame" ] || { echo "$frame: not found" >&2; exit 2; }
venv="$root/target/denoise-venv"
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import pyoidn, OpenEXR, numpy" 2> /dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet pyoidn OpenEXR numpy
fi
"$venv/bin/python" "$here/denoise.py" "$frame" "$out"
