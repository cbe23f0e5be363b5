#!/usr/bin/env bash
# Checks the farm job templates of examples/farm/ on a small scene (not in CI: it installs
# openjd-cli from PyPI):
# - the Open Job Description template passes `openjd check`, and `openjd run` renders every
#   frame of the scene in chunks, after one simulation;
# - the Slurm script's array tasks, run here as Slurm would run them (SLURM_ARRAY_TASK_ID), give
#   the same frames.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release --manifest-path "$root/Cargo.toml" >/dev/null
shatter="$root/target/release/shatter"

python3 -m venv "$work/venv"
"$work/venv/bin/pip" install --quiet openjd-cli
openjd="$work/venv/bin/openjd"

cat > "$work/pipeline.toml" <<'TOML'
[scene]
name = "farm"
output_dir = "out"
seed = 1
[geometry]
source = "box"
box_size_m = [0.01, 0.01, 0.004]
sampler = "grid"
spacing_m = 0.001
horizon_factor = 3.0
[material]
density_kg_m3 = 2200.0
bulk_modulus_pa = 14.9e9
[sim]
frames = 7
steps_per_frame = 20
[render]
backend = "cpu"
resolution = [48, 32]
samples_per_pixel = 1
TOML

"$openjd" check "$root/examples/farm/shatter.openjd.yaml"
"$openjd" run "$root/examples/farm/shatter.openjd.yaml" --step Render --run-dependencies \
    -p Config="$work/pipeline.toml" -p Shatter="$shatter" -p LastFrame=7 -p ChunkSize=3 > "$work/openjd.log"
for frame in 1 2 3 4 5 6 7; do
    test -f "$work/out/render/farm.000$frame.exr" || { echo "openjd run: frame $frame missing" >&2; exit 1; }
done
echo "OpenJD template: checked, and it rendered 7 frames in 3 chunks"

# The Slurm script's commands, run as Slurm would: the simulation, then each array task.
mkdir -p "$work/slurm" && cp "$work/pipeline.toml" "$work/slurm/"
commands=$(DRY_RUN=1 SHATTER="$shatter" "$root/examples/farm/shatter.slurm.sh" "$work/slurm/pipeline.toml" 7 3)
simulate=$(echo "$commands" | sed -n 1p | sed "s/.*--wrap=//")
render=$(echo "$commands" | sed -n 2p | sed "s/.*--wrap=//")
bash -c "$simulate" > /dev/null
for task in 0 1 2; do SLURM_ARRAY_TASK_ID=$task bash -c "$render" > /dev/null; done
for frame in 1 2 3 4 5 6 7; do
    cmp -s "$work/out/render/farm.000$frame.exr" "$work/slurm/out/render/farm.000$frame.exr" \
        || { echo "Slurm array: frame $frame differs from the OpenJD run's" >&2; exit 1; }
done
echo "Slurm script: its array tasks gave the same 7 frames"
