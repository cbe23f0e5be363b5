"""Embree 4 (PyPI `embreex`) on the render benchmark's scene and rays: primary hits per second.

    python3 embree_primary.py WIDTH HEIGHT PROCESSES

The scene is `cargo bench -p shatter-render --bench render`'s: 100 x 100 x 60 cubes of 1 mm, each
turned 0.3 rad about y about its centre, as 12 triangles each (7.2M triangles); the camera and
the rays through the pixel centres are the bench's (eye (0.09, 0.12, 0.11), target
(0, 0.05, 0), 40 degree vertical field of view). embreex traces one ray at a time on one thread,
so PROCESSES processes (each with its own copy of the scene) trace the rows between them, as a
multi-threaded tracer would. Prints the build time, the rays per second (tracing only, all
processes started together; the median of PASSES passes, the slowest process's) and the number
of rays that hit a cube.
"""

import multiprocessing as mp
import sys
import time

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh

# Timed passes of the query; each process reports its median (a pass at the default size takes
# tens of milliseconds, too short for one timing on a shared machine), as the bench does ours.
PASSES = 9

CUBE_TRIANGLES = np.array(
    [[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4],
     [2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]],
    dtype=np.int32,
)


def scene():
    x, y, z = np.meshgrid(np.arange(100), np.arange(100), np.arange(60), indexing="ij")
    centres = np.stack([x.ravel() * 0.001 - 0.05, y.ravel() * 0.001, z.ravel() * 0.001 - 0.03], axis=1)
    c, s = np.cos(0.3), np.sin(0.3)
    rotation = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
    corners = (signs * 0.0005) @ rotation.T
    vertices = (centres[:, None, :] + corners[None, :, :]).reshape(-1, 3).astype(np.float32)
    indices = (CUBE_TRIANGLES[None, :, :] + 8 * np.arange(len(centres), dtype=np.int32)[:, None, None]).reshape(-1, 3)
    built = rtcs.EmbreeScene()
    TriangleMesh(built, vertices, indices)
    return built


def rays(width, height, rows):
    eye = np.array([0.09, 0.12, 0.11])
    forward = np.array([0.0, 0.05, 0.0]) - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan = np.tan(np.radians(40.0) * 0.5)
    px, py = np.meshgrid(np.arange(width) + 0.5, rows + 0.5)
    sx = 2.0 * px.ravel() / width - 1.0
    sy = 1.0 - 2.0 * py.ravel() / height
    d = forward[None, :] + sx[:, None] * right * tan * width / height + sy[:, None] * up * tan
    d /= np.linalg.norm(d, axis=1)[:, None]
    return np.repeat(eye[None, :], len(d), axis=0).astype(np.float32), d.astype(np.float32)


def worker(width, height, rows, start, results):
    began = time.perf_counter()
    built = scene()
    origins, directions = rays(width, height, rows)
    built.run(origins[:1], directions[:1])  # embree builds its BVH at the first query
    build = time.perf_counter() - began
    start.wait()
    seconds = []
    for _ in range(PASSES):
        began = time.perf_counter()
        hits = built.run(origins, directions)
        seconds.append(time.perf_counter() - began)
    median = sorted(seconds)[PASSES // 2]
    results.put((median, int((np.asarray(hits) >= 0).sum()), len(origins), build))


def in_processes(worker, width, height, processes):
    """Runs `worker(width, height, rows, start, results)` in `processes` processes, the image's
    rows shared between them, each waiting at `start` (a barrier) before it times its work and
    puts one tuple on `results`; returns the tuples."""
    start = mp.Barrier(processes)
    results = mp.Queue()
    parts = np.array_split(np.arange(height), processes)
    workers = [mp.Process(target=worker, args=(width, height, rows, start, results)) for rows in parts]
    for w in workers:
        w.start()
    done = [results.get() for _ in workers]
    for w in workers:
        w.join()
    return done


def main():
    width, height, processes = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    done = in_processes(worker, width, height, processes)
    seconds = max(d[0] for d in done)
    hits, count = sum(d[1] for d in done), sum(d[2] for d in done)
    print(f"embree scene of 7,200,000 triangles and its BVH built in {max(d[3] for d in done):.2f} s", flush=True)
    print(
        f"embree {processes} process(es), primary hits: {width} x {height}, median of {PASSES} passes {seconds:.3f} s: "
        f"{count / seconds / 1e6:.2f} M rays/s ({hits} rays hit)",
        flush=True,
    )


if __name__ == "__main__":
    main()
