#!/usr/bin/env bash
# Checks a rendered shatter EXR frame in Blender: runs scripts/check_exr_in_blender.py on the
# frame in the installed `blender` (Debian's, which scripts/test.sh installs; the render tests
# run the same check), or else installs Blender as a Python module (PyPI `bpy`, about 1 GB,
# Python 3.11 for bpy 4.x and 5.x) into a venv under target/ and runs it there.
#
# Usage: scripts/check_exr_in_blender.sh [FRAME.exr]
#   default frame: out/glass_plate_small/render/glass_plate_small.0024.exr (the README's run)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
frame="${1:-$root/out/glass_plate_small/render/glass_plate_small.0024.exr}"
[ -f "$frame" ] || { echo "$frame: not found; run the pipeline first (see README)" >&2; exit 2; }
if command -v blender > /dev/null; then
  exec blender -b --factory-startup --python "$here/check_exr_in_blender.py" -- "$frame"
fi
venv="$root/target/bpy-venv"
python="${PYTHON:-python3.11}"
command -v "$python" > /dev/null || python=python3
if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv "$venv"
  "$venv/bin/pip" install --quiet bpy
fi
"$venv/bin/python" "$here/check_exr_in_blender.py" "$frame"
