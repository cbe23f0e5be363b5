#!/usr/bin/env python3
"""Runs LAMMPS (Debian's `lammps`, `pair_style peri/pmb`) on the fracture cases of
sim/tests/lammps_agreement.rs and keeps its per-atom damage at two times as small fixtures.

    python3 sim/tests/lammps/make_fixtures.py    # needs `lmp` on the PATH; writes sim/tests/lammps/*.damage

Each case runs as given, and again from states strained by moving every atom by up to 1e-12 m
and (four seeds) by up to 1e-10 m at random after the bonds are made: LAMMPS's own spread. 1e-10
m is about the resolution of single-precision positions in these blocks (shatter's CPU and GPU
backends first differ by 2.3e-10 m), so a time at which that spread exceeds 5% is chaotic for a
single-precision code, and the tests compare distributions there: the header's `# spread` lines
give, per dump step, the least and largest mean damage and count of particles over half damaged
over the runs (the unperturbed one included). A fixture line is
`ix iy iz damage_at_t1 damage_at_t2` for each atom, (ix, iy, iz) its lattice cell: the atom sits
at ((ix + 0.5) a, (iy + 0.5) a, (iz + 0.5) a). The Rust tests build the same lattice with the grid
sampler and match particles to atoms by cell.
"""

import math
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))

# LAMMPS's own peri example (examples/peri/in.peri.pmb): glass, a = 0.5 mm, delta = 3.0002 a
A = 0.0005
DELTA = 0.0015001
C = 1.6863e22
S00 = 0.0005
ALPHA = 0.25
DENSITY = 2200.0
DT = 1.0e-7

# name: (cells x, y, z; indenter radius, its gap above the top, speed (m/s, downwards), K, the two
# dump steps)
CASES = {
    "indented_block": ((16, 8, 16), 0.0015, 0.00005, 20.0, 1.0e17, (1500, 3000)),
    "struck_plate": ((24, 4, 24), 0.0015, 0.00005, 300.0, 1.0e17, (350, 700)),
}


# the perturbed runs: (amplitude in metres, seed)
PERTURBATIONS = [(1e-12, 4711), (1e-10, 4711), (1e-10, 815), (1e-10, 999), (1e-10, 31337)]


def script(cells, radius, gap, speed, k, steps, dump, jitter):
    nx, ny, nz = cells
    top = ny / 2 * A - 0.5 * A
    y0 = top + radius + gap
    lines = [
        "units si",
        "boundary s s s",
        "atom_style peri",
        "atom_modify map array",
        "neighbor 0.0010 bin",
        f"lattice sc {A} origin 0.5 0.5 0.5",
        f"region target block {-nx / 2} {nx / 2} {-ny / 2} {ny / 2} {-nz / 2} {nz / 2}",
        "create_box 1 target",
        "create_atoms 1 region target",
        "pair_style peri/pmb",
        f"pair_coeff * * {C} {DELTA} {S00} {ALPHA}",
        f"set group all density {DENSITY}",
        f"set group all volume {A ** 3}",
    ]
    lines += [
        "velocity all set 0.0 0.0 0.0 sum no units box",
        # the bonds are made at the first run: a perturbation after it strains them
        "run 0",
    ]
    if jitter:
        amplitude, seed = jitter
        lines.append(f"displace_atoms all random {amplitude} {amplitude} {amplitude} {seed} units box")
    lines += [
        "fix 1 all nve",
        f"variable y equal \"{y0} - step*dt*{speed}\"",
        f"fix 2 all indent {k} sphere 0.0 v_y 0.0 {radius} units box",
        "compute 1 all damage/atom",
        f"timestep {DT}",
        "thermo 500",
        f"dump 1 all custom {math.gcd(*steps)} {dump} id x y z c_1",
        "dump_modify 1 sort id",
        f"run {steps[1]}",
    ]
    return "\n".join(lines) + "\n"


def run(cells, radius, gap, speed, k, steps, jitter=None):
    """LAMMPS's damage by lattice cell at the two dump steps."""
    with tempfile.TemporaryDirectory() as work:
        dump = os.path.join(work, "dump")
        with open(os.path.join(work, "in"), "w") as f:
            f.write(script(cells, radius, gap, speed, k, steps, dump, jitter))
        subprocess.run(["lmp", "-in", "in", "-log", "log"], cwd=work, check=True, capture_output=True)
        frames = {}
        with open(dump) as f:
            lines = f.read().split("\n")
        i = 0
        while i < len(lines):
            if lines[i] == "ITEM: TIMESTEP":
                step = int(lines[i + 1])
                count = int(lines[i + 3])
                atoms = [lines[i + 9 + n].split() for n in range(count)]
                frames[step] = {int(a[0]): (float(a[1]), float(a[2]), float(a[3]), float(a[4])) for a in atoms}
                i += 9 + count
            else:
                i += 1
    start = frames[0]
    cell = {atom: tuple(int(math.floor(p / A)) for p in xyz[:3]) for atom, xyz in start.items()}
    return {cell[atom]: tuple(frames[s][atom][3] for s in steps) for atom in start}


def correlation(a, b):
    n = len(a)
    ma, mb = sum(a) / n, sum(b) / n
    cov = sum((x - ma) * (y - mb) for x, y in zip(a, b))
    va = sum((x - ma) ** 2 for x in a)
    vb = sum((y - mb) ** 2 for y in b)
    return cov / math.sqrt(va * vb) if va > 0 and vb > 0 else 1.0


def main():
    for name, (cells, radius, gap, speed, k, steps) in CASES.items():
        damage = run(cells, radius, gap, speed, k, steps)
        runs = [damage] + [run(cells, radius, gap, speed, k, steps, jitter) for jitter in PERTURBATIONS]
        keys = sorted(damage)
        header = [
            f"# LAMMPS peri/pmb, {name}: {cells[0]} x {cells[1]} x {cells[2]} cells of a = {A} m, delta = {DELTA} m,",
            f"# c = {C}, s00 = {S00}, alpha = {ALPHA}, density {DENSITY}, dt = {DT} s; an indenter of radius {radius} m,",
            f"# K = {k} (fix indent), {gap} m above the top, moving down at {speed} m/s; damage at steps {steps[0]} and",
            f"# {steps[1]}. Made by sim/tests/lammps/make_fixtures.py with {version()}.",
        ]
        for t, step in enumerate(steps):
            a = [damage[c][t] for c in keys]
            for (amplitude, seed), other in zip(PERTURBATIONS, runs[1:]):
                b = [other[c][t] for c in keys]
                header.append(
                    f"# perturbed by {amplitude} m (seed {seed}), step {step}: mean damage {sum(b) / len(b):.5f}, "
                    f"over half damaged {sum(x > 0.5 for x in b)}, correlation {correlation(a, b):.4f}"
                )
            means = [sum(r[c][t] for c in keys) / len(keys) for r in runs]
            counts = [sum(r[c][t] > 0.5 for c in keys) for r in runs]
            header.append(f"# spread {step} {min(means):.6f} {max(means):.6f} {min(counts)} {max(counts)}")
        with open(os.path.join(HERE, f"{name}.damage"), "w") as f:
            f.write("\n".join(header) + "\n")
            for c in keys:
                f.write(f"{c[0]} {c[1]} {c[2]} {damage[c][0]:.6f} {damage[c][1]:.6f}\n")
        print("\n".join(header))


def version():
    out = subprocess.run(["lmp", "-h"], capture_output=True, text=True).stdout
    for line in out.split("\n"):
        if "Large-scale" in line:
            return "LAMMPS " + line.split(" - ", 1)[1].strip()
    return "LAMMPS"


if __name__ == "__main__":
    sys.exit(main())
