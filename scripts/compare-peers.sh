#!/usr/bin/env bash
# Measures shatter against its peers on this machine, side by side in the same runs, and prints
# the min, median and max of each ratio (shatter's speed over the peer's) over RUNS runs
# (default 3), the programs alternating within each run:
# - the CPU simulation against LAMMPS (Debian's `lammps`): peri/pmb on a lattice (the
#   `bond_updates` bench, which runs LAMMPS itself) and on tet-shell and Voronoi particles
#   (`irregular_bond_updates`, which writes them as a LAMMPS data file), peri/lps and peri/eps
#   against the elastoplastic model (`elastoplastic_updates`);
# - Delaunay tetrahedralization against TetGen (PyPI `tetgen`) and qhull (scipy) on the same
#   200,000 points in three layouts;
# - nearest hits of camera rays against Embree 4 (PyPI `embreex`) on the render bench's scene
#   and rays, on one thread (one process) and on all cores (as many processes); our shaded
#   primary rays beside them; and full glass paths (8 events), our glass pass against Embree's
#   ray queries alone for the same paths (`peers/embree_glass.py`).
#
#   scripts/compare-peers.sh [RUNS [GROUPS]]
#
# GROUPS (comma-separated; default all) picks comparisons: lattice, irregular, elastoplastic, delaunay,
# render. The lattice and irregular groups run once per SIMD path this CPU has (portable, avx2,
# avx512), each ratio named with its path; SHATTER_SIMD=PATH runs one path only.
#
# It installs what is missing: lammps with apt-get (as root), the Python peers into .peers-venv/
# (ignored by git). Takes about 17 minutes a run on 2 cores (the lattice and irregular groups about 3, render about 2.5).
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
if ! command -v lmp >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ]; then
    apt-get install -y -q --no-install-recommends lammps >/dev/null || apt-get update -q >/dev/null
    command -v lmp >/dev/null 2>&1 || apt-get install -y -q --no-install-recommends lammps >/dev/null
  else
    echo "compare-peers: LAMMPS (lmp) is missing: install Debian's lammps package" >&2
  fi
fi
venv=.peers-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv" || { apt-get install -y -q python3-venv >/dev/null && python3 -m venv "$venv"; }
fi
"$venv/bin/python" -c "import embreex, tetgen, scipy" 2>/dev/null \
  || "$venv/bin/pip" install -q embreex tetgen scipy numpy
cargo bench --locked -p shatter-sim --bench bond_updates --bench irregular_bond_updates --bench elastoplastic_updates --no-run -q
cargo bench --locked -p shatter-preprocess --bench delaunay --no-run -q
cargo bench --locked -p shatter-render --bench render --no-run -q
exec "$venv/bin/python" scripts/peers/compare.py "$runs" ${2:+"$2"}
