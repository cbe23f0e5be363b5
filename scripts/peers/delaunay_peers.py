"""Times qhull (scipy.spatial.Delaunay) and TetGen (PyPI `tetgen`) on the points the Delaunay
benchmark wrote (`cargo bench -p shatter-preprocess --bench delaunay -- --points-dir DIR`).

    python3 delaunay_peers.py DIR

Prints one line per layout and program: "<program> <layout>: <seconds> s, <tets> tets".
TetGen's Python binding tetrahedralizes a surface with the points inside it, so it gets the
points with the 8 corners of a box around them (switches "pQ": every input point is a vertex);
its tets are within a few dozen of qhull's on 200,000 points.
"""

import sys
import time
from pathlib import Path

import numpy as np
import tetgen
from scipy.spatial import Delaunay

BOX_FACES = np.array(
    [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
     [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]],
    dtype=np.int32,
)


def with_box(points):
    span = points.max(0) - points.min(0)
    lo, hi = points.min(0) - 0.01 * span, points.max(0) + 0.01 * span
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    return np.vstack([corners, points])


def main():
    folder = Path(sys.argv[1])
    for path in sorted(folder.glob("*.f64")):
        layout = path.stem.replace("_", " ")
        points = np.fromfile(path, dtype="<f8").reshape(-1, 3)
        started = time.perf_counter()
        tets = Delaunay(points).simplices
        print(f"qhull {layout}: {time.perf_counter() - started:.3f} s, {len(tets)} tets", flush=True)
        mesher = tetgen.TetGen(with_box(points), BOX_FACES)
        started = time.perf_counter()
        _, elements = mesher.tetrahedralize(switches="pQ")[:2]
        print(f"tetgen {layout}: {time.perf_counter() - started:.3f} s, {len(elements)} tets", flush=True)


if __name__ == "__main__":
    main()
