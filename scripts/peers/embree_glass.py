"""Embree 4 (PyPI `embreex`) tracing the render benchmark's full glass paths: rays per second.

    python3 embree_glass.py WIDTH HEIGHT PROCESSES

The scene, camera and pixel-centre rays are `embree_primary.py`'s (the render bench's 600,000
cubes as 7.2M triangles). Each pixel's path follows the bench's glass pass (`max_bounces` 8,
`glass_split_events` 2, index of refraction 1.5, absorption (1, 0.3, 0.6) per metre, a constant
environment of 1): it enters the glass at its nearest hit, walks through the union of cubes to
where it ends, and there reflects inside or refracts out by Schlick's Fresnel term; the first
two interface events of a path split it into both branches, later ones choose one with the
tracer's own hash (`trace::random`, same pixel, sample and event numbers), so the paths are the
bench's paths. Embree has no union of solids: inside the glass, a path crosses every face it
meets with one more ray query from the crossing point for as long as the point just past it
lies in a cube (the cubes are turned about their centres, so neighbours overlap and leave
gaps), as shatter's walk steps from cube to cube until no cube holds the point.

The paths run as a wavefront: all paths take their next event together, each event's ray
queries one `run` call over all of them. Two times are printed: all of it (NumPy does the
shading, as our tracer's own code does) and Embree's queries alone, the least a tracer built on
Embree would take for these paths. PROCESSES processes trace the rows between them.
"""

import sys
import time

import numpy as np

from embree_primary import in_processes, rays, scene

IOR = np.float32(1.5)
ABSORPTION = np.array([1.0, 0.3, 0.6], dtype=np.float32)
MAX_BOUNCES = 8
SPLIT_EVENTS = 2
BRANCH_EVENTS = 128
GRID = (100, 100, 60)
ANGLE = 0.3
HALF = 0.0005
# WIDEN (2e-5) of the cube's size: the tracer's slack; its ray offsets are 4 slacks
EPS = np.float32(4.0 * 2e-5 * 2.0 * HALF)
MASK = np.uint64(0xFFFFFFFF)


def hash32(x):
    """trace::hash32, on uint64 arrays holding 32-bit values."""
    state = (x * np.uint64(747_796_405) + np.uint64(2_891_336_453)) & MASK
    word = (((state >> ((state >> np.uint64(28)) + np.uint64(4))) ^ state) * np.uint64(277_803_737)) & MASK
    return (word >> np.uint64(22)) ^ word


def random(pixel, event):
    """trace::random for sample 0: a uniform number in [0, 1) per (pixel, event)."""
    inner = hash32(hash32(event.astype(np.uint64)))  # sample 0 hashes as 0 ^ hash32(event)
    bits = hash32(pixel.astype(np.uint64) ^ inner)
    return (bits >> np.uint64(8)).astype(np.float32) / np.float32(1 << 24)


def rotation():
    c, s = np.cos(ANGLE), np.sin(ANGLE)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def face_normals():
    """Outward unit normals of a cube's faces in the triangles' order (-x, +x, -y, +y, -z, +z)."""
    axes = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]], dtype=np.float64)
    return (axes @ rotation().T).astype(np.float32)


NEIGHBOURS = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])


def in_union(points, cube):
    """Whether each point lies in a cube (widened by the tracer's slack); `cube` is one whose
    surface it is next to, so only that cube and its 26 grid neighbours can hold it. The cubes
    are turned about their centres, so neighbours overlap and leave gaps: this is the test that
    decides where shatter's walk through the union ends."""
    x, rest = np.divmod(cube, GRID[1] * GRID[2])
    y, z = np.divmod(rest, GRID[2])
    index = np.stack([x, y, z], axis=1)[:, None, :] + NEIGHBOURS[None, :, :]
    valid = ((index >= 0) & (index < np.array(GRID))).all(axis=2)
    centres = index * 0.001 - np.array([0.05, 0.0, 0.03])
    local = (points[:, None, :].astype(np.float64) - centres) @ rotation()
    inside = (np.abs(local) <= HALF + 2e-5 * 2.0 * HALF).all(axis=2)
    return (inside & valid).any(axis=1)


def dot(a, b):
    return (a * b).sum(axis=1)


def refract(d, n, eta):
    """Refraction of d at normal n facing against it; ok False on total internal reflection."""
    cos_i = -dot(d, n)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    ok = sin2_t <= 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    k = eta * cos_i - cos_t
    return eta * d + k[:, None] * n, ok


def fresnel(cos_i, eta):
    r0 = ((1.0 - eta) / (1.0 + eta)) ** 2
    return r0 + (1.0 - r0) * (1.0 - np.clip(cos_i, 0.0, 1.0)) ** 5


def reflect(d, n):
    return d - (2.0 * dot(d, n))[:, None] * n


class Timed:
    """An Embree scene whose queries are timed."""

    def __init__(self, built):
        self.built, self.seconds, self.queries = built, 0.0, 0

    def nearest(self, origins, directions):
        """(t, primitive) of each ray's nearest hit (primitive -1 for none)."""
        began = time.perf_counter()
        found = self.built.run(origins, directions, output=1)
        self.seconds += time.perf_counter() - began
        self.queries += len(origins)
        return np.asarray(found["tfar"], dtype=np.float32), np.asarray(found["primID"])


def union_exit(embree, normals, origins, directions):
    """Where rays inside the glass leave the union: (distance, outward normal there). Every face
    the ray meets is crossed with one more query while the point just past it is in a cube."""
    count = len(origins)
    travelled = np.zeros(count, dtype=np.float32)
    normal = -directions.copy()  # a ray that finds no face (numerically outside) leaves where it is
    walking = np.arange(count)
    point = origins.copy()
    offset = np.zeros(count, dtype=np.float32)  # 0 from the path's own origin, EPS past a crossing
    while len(walking):
        start = point[walking] + offset[walking, None] * directions[walking]
        t, primitive = embree.nearest(start, directions[walking])
        found = primitive >= 0
        walking, t, primitive = walking[found], t[found] + offset[walking[found]], primitive[found]
        travelled[walking] += t
        point[walking] += t[:, None] * directions[walking]
        cube, face = np.divmod(primitive, 12)
        normal[walking] = normals[face // 2]
        offset[walking] = EPS
        walking = walking[in_union(point[walking] + EPS * directions[walking], cube)]
    return travelled, normal


def nearest_entry(embree, normals, origins, directions):
    """Each ray's nearest cube entry from outside the glass (t, face normal; t infinite for
    none): faces it meets from inside a cube it starts in are passed, as shatter counts only
    entries (t_in >= 0)."""
    count = len(origins)
    hit_t = np.full(count, np.inf, dtype=np.float32)
    normal = np.zeros((count, 3), dtype=np.float32)
    travelled = np.zeros(count, dtype=np.float32)
    searching = np.arange(count)
    while len(searching):
        start = origins[searching] + travelled[searching, None] * directions[searching]
        t, primitive = embree.nearest(start, directions[searching])
        found = primitive >= 0
        searching, t, primitive = searching[found], t[found], primitive[found]
        n = normals[(primitive % 12) // 2]
        entering = dot(directions[searching], n) < 0.0
        done = searching[entering]
        hit_t[done] = travelled[done] + t[entering]
        normal[done] = n[entering]
        travelled[searching] += t + EPS
        searching = searching[~entering]
    return hit_t, normal


def trace(embree, width, rows, origins, directions):
    """Traces the pixels' paths; returns each pixel's colour."""
    normals = face_normals()
    pixels = len(origins)
    pixel_ids = ((rows[:, None] * width + np.arange(width)[None, :]).ravel()).astype(np.int64)
    colour = np.zeros((pixels, 3), dtype=np.float32)
    # path state: pixel, role (0 main, 1 reflected at the main path's first event, 2 at its
    # second, 3 reflected at role 1's second event), origin, direction, throughput, inside
    pixel = np.arange(pixels)
    role = np.zeros(pixels, dtype=np.int64)
    o, d = origins.astype(np.float32), directions.astype(np.float32)
    throughput = np.ones((pixels, 3), dtype=np.float32)
    inside = np.zeros(pixels, dtype=bool)
    main_split_twice = np.zeros(pixels, dtype=bool)
    for event in range(MAX_BOUNCES):
        if not len(pixel):
            break
        # trace_ray's branch numbers: branches run main path first, then the stack's last first
        first_reflected = np.where(main_split_twice[pixel], 2, 1)
        branch = np.choose(role, [np.zeros_like(role), first_reflected, np.ones_like(role), first_reflected + 1])
        chance = random(pixel_ids[pixel], np.full(len(pixel), event) + branch * BRANCH_EVENTS)
        splits = event + 1 <= SPLIT_EVENTS
        new = []  # reflected branches split off (pixel, role, origin, direction, throughput, inside)
        keep = np.ones(len(pixel), dtype=bool)
        # inside: to the union's end, then reflect inside or refract out
        inner, outer = np.flatnonzero(inside), np.flatnonzero(~inside)
        if len(inner):
            t, m = union_exit(embree, normals, o[inner], d[inner])
            exit_point = o[inner] + t[:, None] * d[inner]
            throughput[inner] *= np.exp(-ABSORPTION[None, :] * t[:, None])
            refracted, ok = refract(d[inner], -m, IOR)
            reflectance = fresnel(dot(d[inner], m), IOR)
            reflected_o, reflected_d = exit_point - EPS * m, reflect(d[inner], m)
            if splits:
                split = ok
                fresh = inner[split]
                new.append((pixel[fresh], np.where(role[fresh] == 0, 2, 3), reflected_o[split], reflected_d[split],
                            throughput[fresh] * reflectance[split, None], np.ones(len(fresh), dtype=bool)))
                main_split_twice[pixel[fresh[role[fresh] == 0]]] = True
                throughput[fresh] *= (1.0 - reflectance[split])[:, None]
                out = ok
            else:
                out = ok & (chance[inner] >= reflectance)
            o[inner] = np.where(out[:, None], exit_point + EPS * m, reflected_o)
            d[inner] = np.where(out[:, None], refracted, reflected_d)
            inside[inner] = ~out
        # outside: the nearest hit, or the environment
        if len(outer):
            t, n = nearest_entry(embree, normals, o[outer], d[outer])
            missed = ~np.isfinite(t)
            colour_add = outer[missed]
            np.add.at(colour, pixel[colour_add], throughput[colour_add])
            keep[colour_add] = False
            hit, n = outer[~missed], n[~missed]
            p = o[hit] + t[~missed, None] * d[hit]
            reflectance = fresnel(-dot(d[hit], n), np.float32(1.0) / IOR)
            refracted, _ = refract(d[hit], n, np.float32(1.0) / IOR)
            reflected_o, reflected_d = p + EPS * n, reflect(d[hit], n)
            if splits:
                new.append((pixel[hit], np.where(role[hit] == 0, 1, 3), reflected_o, reflected_d,
                            throughput[hit] * reflectance[:, None], np.zeros(len(hit), dtype=bool)))
                throughput[hit] *= (1.0 - reflectance)[:, None]
                into = np.ones(len(hit), dtype=bool)
            else:
                into = chance[hit] >= reflectance
            o[hit] = np.where(into[:, None], p - EPS * n, reflected_o)
            d[hit] = np.where(into[:, None], refracted, reflected_d)
            inside[hit] = into
        for fresh in new:
            pixel = np.concatenate([pixel, fresh[0]])
            role = np.concatenate([role, fresh[1]])
            o, d = np.concatenate([o, fresh[2]]), np.concatenate([d, fresh[3]])
            throughput = np.concatenate([throughput, fresh[4]])
            inside = np.concatenate([inside, fresh[5]])
            keep = np.concatenate([keep, np.ones(len(fresh[0]), dtype=bool)])
        pixel, role, o, d, throughput, inside = (a[keep] for a in (pixel, role, o, d, throughput, inside))
    # out of bounces: the rest escape to the environment
    np.add.at(colour, pixel, throughput)
    return colour


def worker(width, height, rows, start, results):
    built = scene()
    origins, directions = rays(width, height, rows)
    built.run(origins[:1], directions[:1])  # embree builds its BVH at the first query
    embree = Timed(built)
    start.wait()
    began = time.perf_counter()
    colour = trace(embree, width, rows, origins, directions)
    seconds = time.perf_counter() - began
    results.put((seconds, embree.seconds, embree.queries, len(origins), float(colour.sum(dtype=np.float64))))


def main():
    width, height, processes = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    done = in_processes(worker, width, height, processes)
    seconds, queries_s = max(d[0] for d in done), max(d[1] for d in done)
    queries, count, total = sum(d[2] for d in done), sum(d[3] for d in done), sum(d[4] for d in done)
    print(
        f"embree {processes} process(es), glass paths, {MAX_BOUNCES} events: {width} x {height} in {seconds:.2f} s: "
        f"{count / seconds / 1e6:.3f} M rays/s; its {queries} ray queries alone {queries_s:.2f} s: "
        f"{count / queries_s / 1e6:.3f} M rays/s (mean colour {total / (3 * count):.5f})",
        flush=True,
    )


if __name__ == "__main__":
    main()
