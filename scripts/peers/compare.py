"""Runs shatter's benchmarks and its peers' side by side, RUNS times, and prints the min, median
and max of each ratio (how many times faster shatter is than the peer; the target beside it).
Called by scripts/compare-peers.sh, which installs the peers first.

    python3 compare.py RUNS [GROUPS]

GROUPS, comma-separated, picks comparisons (default all): lattice, irregular, elastoplastic, delaunay,
render. The lattice and row-layout (irregular) comparisons run once per SIMD path this CPU has
(portable, avx2, avx512), each forced through SHATTER_SIMD; set SHATTER_SIMD to run one path only.
The elastoplastic model, the Delaunay code and the tracer have one path.
"""

import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PEERS = Path(__file__).resolve().parent


def bench(package, name, args, threads=None, simd=None):
    env = dict(os.environ)
    if threads is not None:
        env["RAYON_NUM_THREADS"] = str(threads)
    if simd is not None:
        env["SHATTER_SIMD"] = simd
    command = ["cargo", "bench", "--locked", "-q", "-p", package, "--bench", name, "--", *args]
    return run(command, env)


def python(script, args):
    return run([sys.executable, str(PEERS / script), *map(str, args)], dict(os.environ))


def run(command, env):
    done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.exit(f"compare-peers: {' '.join(command)} failed:\n{done.stdout}\n{done.stderr}")
    return done.stdout


def number(pattern, text, what):
    found = re.search(pattern, text, re.MULTILINE)
    if not found:
        sys.exit(f"compare-peers: no {what} in:\n{text}")
    return float(found.group(1))


GROUPS = ("lattice", "irregular", "elastoplastic", "delaunay", "render")


def simd_paths():
    """The SIMD paths to compare: SHATTER_SIMD's, else every path this CPU's flags allow."""
    if os.environ.get("SHATTER_SIMD"):
        return [os.environ["SHATTER_SIMD"]]
    try:
        found = re.search(r"^flags\s*:(.*)$", Path("/proc/cpuinfo").read_text(), re.MULTILINE)
        flags = set(found.group(1).split()) if found else set()
    except OSError:
        flags = set()
    return ["portable"] + [path for path, flag in (("avx2", "avx2"), ("avx512", "avx512f")) if flag in flags]


def simd_bench(name, args, simd):
    """A simulation bench on one SIMD path; checks that the bench ran it."""
    text = bench("shatter-sim", name, args, simd=simd)
    if f", {simd} kernels;" not in text:
        sys.exit(f"compare-peers: {name} did not run the {simd} kernels:\n{text}")
    return text


def one_run(ratios, cores, groups):
    def add(name, value):
        ratios.setdefault(name, []).append(value)
        print(f"  {name}: {value:.2f}x", flush=True)

    for simd in simd_paths() if "lattice" in groups else []:
        text = simd_bench("bond_updates", ["100"], simd)
        add(f"CPU simulation vs LAMMPS peri/pmb, lattice, per core, {simd}", number(r"per-core ratio, shatter 1 thread / LAMMPS: ([\d.]+)x", text, "LAMMPS ratio"))
    for simd in simd_paths() if "irregular" in groups else []:
        text = simd_bench("irregular_bond_updates", ["20"], simd)
        for case in ("tet shell (filled core)", "Voronoi cells"):
            pattern = rf"per-core ratio, shatter 1 thread / LAMMPS, {re.escape(case)}: ([\d.]+)x"
            add(f"CPU simulation vs LAMMPS peri/pmb, {case}, per core, {simd}", number(pattern, text, f"{case} ratio"))
    if "elastoplastic" in groups:
        text = bench("shatter-sim", "elastoplastic_updates", ["20"])
        for style in ("lps", "eps"):
            add(f"elastoplastic vs LAMMPS peri/{style}, per core", number(rf"LAMMPS peri/{style}, 1 core:.*ratio ([\d.]+)x", text, style))
    if "delaunay" in groups:
        delaunay(add)
    if "render" in groups:
        render(add, cores)


def delaunay(add):
    with tempfile.TemporaryDirectory() as folder:
        ours = bench("shatter-preprocess", "delaunay", ["--points-dir", folder])
        peers = python("delaunay_peers.py", [folder])
    for layout in ("random cube", "nested shells", "offset shells"):
        seconds = number(rf"^\s*{layout}:\s+([\d.]+) s", ours, f"our {layout} time")
        for peer in ("tetgen", "qhull"):
            theirs = number(rf"^{peer} {layout}: ([\d.]+) s", peers, f"{peer} {layout} time")
            add(f"Delaunay vs {'TetGen' if peer == 'tetgen' else 'qhull'}, {layout} (time ratio)", theirs / seconds)


def render(add, cores):
    # Embree's figure is nearest hits, unshaded: ours beside it is the same query; our shaded
    # primary rays (the glass's Fresnel split and two environment lookups per hit) are shown too.
    # Full glass paths: Embree's ray queries alone for the same paths (embree_glass.py), against
    # our whole glass pass; the two images' means must agree, or the paths were not the same.
    for threads in (1, cores):
        ours = bench("shatter-render", "render", ["640", "360"], threads=threads)
        nearest = number(r"CPU \(\d+ threads?\), nearest hits: .* s: ([\d.]+) M rays/s", ours, "our nearest-hit rate")
        shaded = number(r"CPU \(\d+ threads?\), primary hits only: .* s: ([\d.]+) M rays/s", ours, "our ray rate")
        glass = number(r"CPU \(\d+ threads?\), glass paths, 8 events: .* s: ([\d.]+) M rays/s", ours, "our glass path rate")
        our_mean = number(r"glass paths, 8 events: .*mean colour ([\d.]+)", ours, "our glass image's mean")
        theirs = python("embree_primary.py", [640, 360, threads])
        embree = number(r"primary hits: .* s: ([\d.]+) M rays/s", theirs, "Embree's ray rate")
        add(f"nearest hits vs Embree, {threads} thread(s) / process(es)", nearest / embree)
        add(f"primary rays shaded vs Embree's nearest hits, {threads} thread(s) / process(es)", shaded / embree)
        theirs = python("embree_glass.py", [640, 360, threads])
        embree_glass = number(r"ray queries alone .* s: ([\d.]+) M rays/s", theirs, "Embree's glass path rate")
        their_mean = number(r"mean colour ([\d.]+)", theirs, "Embree's glass image's mean")
        if abs(their_mean - our_mean) > 1e-3 * our_mean:
            sys.exit(f"compare-peers: the glass images differ (mean {our_mean} against Embree's {their_mean})")
        add(f"full glass paths vs Embree's ray queries alone, {threads} thread(s) / process(es)", glass / embree_glass)


def main():
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    groups = sys.argv[2].split(",") if len(sys.argv) > 2 else list(GROUPS)
    unknown = [g for g in groups if g not in GROUPS]
    if unknown:
        sys.exit(f"compare-peers: unknown group {unknown[0]!r} (groups: {', '.join(GROUPS)})")
    cores = os.cpu_count() or 1
    ratios = {}
    for k in range(runs):
        print(f"run {k + 1} of {runs}", flush=True)
        one_run(ratios, cores, groups)
    targets = {
        "CPU simulation vs LAMMPS peri/pmb, lattice": ">= 15x",
        "CPU simulation vs LAMMPS peri/pmb, tet": ">= 10x",
        "CPU simulation vs LAMMPS peri/pmb, Voronoi": ">= 10x",
        "elastoplastic vs LAMMPS": ">= 10x",
        "Delaunay vs TetGen": ">= 1x",
        "nearest hits vs Embree": ">= 1x",
        "full glass paths vs Embree": ">= 1x",
    }
    print(f"\n| comparison ({runs} runs, {cores} cores) | min | median | max | target |")
    print("|---|---|---|---|---|")
    for name, values in ratios.items():
        target = next((t for prefix, t in targets.items() if name.startswith(prefix)), "")
        print(f"| {name} | {min(values):.2f}x | {statistics.median(values):.2f}x | {max(values):.2f}x | {target} |")


if __name__ == "__main__":
    main()
