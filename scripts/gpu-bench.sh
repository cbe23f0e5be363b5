#!/usr/bin/env bash
# Everything only a real GPU can show, in one command, printed as a table for docs/PERFORMANCE.md#gpu:
# - the GPU simulation's steps per second and ms per step on the paper's scenes (the glass plate,
#   the vase and the dragon, each on its own particle file and model) and on grid blocks standing
#   in for them (vase and dragon scale, and an elastoplastic block), beside the bandwidth floor of
#   the bytes each step moves;
# - the GPU tracer's primary-hit and full-glass-path rays per second at 1920 x 1080 x 4 spp, on
#   600,000 cubes and on dragon_paper's 473,749 trimtopes (its cells made by `shatter preprocess`
#   with a small horizon: the tracer needs the cells, not the bonds);
# - CPU-vs-GPU agreement: the simulation's state after the same steps on both backends, and the
#   tracer's images against the CPU's.
#
#   scripts/gpu-bench.sh [all|build|run|shots]
#
# `shots` runs the paper-scale real-speed shots end to end with the `shatter` binary that
# `build` also packs (the GPU simulates; the follow-through runs on the machine's cores), each
# bounded in time, and prints each stage's time and what `shatter inspect` says of the
# follow-through's end (pieces still awake, the deepest overlap):
#   SHATTER_GPU_SHOTS         scene configs (default: vase_drop_paper, glass_plate_shot_paper,
#                             dragon_drop_paper)
#   SHATTER_GPU_SHOT_S        bound on each shot's run (default 300 s; vase_drop_paper reaches
#                             its render in about 250 s on an H200)
#   SHATTER_GPU_SHOT_UNTIL    the last stage run (default rigid; render for the frames too)
#
# `build` compiles the two benchmarks (sim's gpu_steps, render's render) in release mode and puts
# them, stripped and compressed, in .gpu-bench/ (ignored by git). `run` runs them from there and
# needs no Rust toolchain, so a machine without one and without network (a lent GPU machine) can
# run what was built here: carry .gpu-bench (and .gl, see below) to it. `all` (the default) does
# both. On a machine without a hardware GPU it runs the small cases on a software adapter (Mesa
# lavapipe), only to show the path works.
#
# Environment:
#   SHATTER_GPU_BENCH_SCENES  scene configs to run (default: the paper-scale plate, vase and dragon
#                             on a hardware GPU, their small presets on a software adapter)
#   SHATTER_GPU_BENCH_STEPS   steps timed per case (default 200; 20 on a software adapter)
#   SHATTER_GPU_ADAPTER       pick an adapter by name; SHATTER_GPU_BANDWIDTH_GBS: its nominal bandwidth
#   SHATTER_GPU_BENCH_TRACER_S  bound on the tracer benchmark's run (default 300 s)
# A bare machine without a Vulkan loader: put Debian's libvulkan1 and libglvnd0 .debs in .gl/ (the
# device tool's README says how; NVIDIA's Vulkan driver is libGLX_nvidia, which needs glvnd's
# libGLdispatch: without it the loader finds no adapter); `run` and `shots` unpack them and point
# the loader at NVIDIA's driver when they find it.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
mode=${1:-all}
bench_dir=$root/.gpu-bench

build() {
  mkdir -p "$bench_dir"
  local package bench exe
  for pair in shatter-sim:gpu_steps shatter-render:render; do
    package=${pair%%:*}
    bench=${pair##*:}
    exe=$(cargo bench --locked -p "$package" --bench "$bench" --no-run --message-format=json 2>/dev/null \
      | sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)
    [ -x "$exe" ] || { echo "gpu-bench: could not build $package's $bench benchmark" >&2; exit 1; }
    strip -o "$bench_dir/$bench" "$exe"
    gzip -9 -f "$bench_dir/$bench"
  done
  cargo build --locked --release --bin shatter 2>/dev/null || { echo "gpu-bench: could not build shatter" >&2; exit 1; }
  strip -o "$bench_dir/shatter" target/release/shatter
  gzip -9 -f "$bench_dir/shatter"
  echo "gpu-bench: built $(ls "$bench_dir")  in .gpu-bench/ ($(du -sh "$bench_dir" | cut -f1))"
}

vulkan() {
  local libs
  libs=$(ldconfig -p 2>/dev/null || true)
  if { ! grep -q 'libvulkan.so.1' <<<"$libs" || ! grep -q 'libGLdispatch.so.0' <<<"$libs"; } && ls .gl/*.deb >/dev/null 2>&1; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
  fi
  local icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  if [ -z "${VK_DRIVER_FILES:-}" ] && [ -f "$icd" ]; then
    export VK_DRIVER_FILES=$icd
    export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
  fi
  export NODEVICE_SELECT=1
}

run() {
  vulkan
  local bin
  bin=$(mktemp -d)
  for bench in gpu_steps render shatter; do
    [ -f "$bench_dir/$bench.gz" ] || { echo "gpu-bench: .gpu-bench/$bench.gz is missing: run '$0 build' first" >&2; exit 1; }
    gunzip -c "$bench_dir/$bench.gz" >"$bin/$bench"
    chmod +x "$bin/$bench"
  done
  local hardware=1
  if command -v nvidia-smi >/dev/null 2>&1; then nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader || true; fi
  # the benchmarks fall back to a software adapter themselves; the scenes follow what they find
  if ! "$bin/gpu_steps" --adapter | grep -q '^hardware'; then hardware=0; fi
  local steps scenes cells
  if [ "$hardware" = 1 ]; then
    steps=${SHATTER_GPU_BENCH_STEPS:-200}
    scenes=${SHATTER_GPU_BENCH_SCENES:-assets/scenes/glass_plate_paper.toml assets/scenes/vase_paper.toml assets/scenes/dragon_paper.toml}
    cells=assets/scenes/dragon_paper.toml
  else
    export SHATTER_GPU_ALLOW_SOFTWARE=1
    steps=${SHATTER_GPU_BENCH_STEPS:-20}
    scenes=${SHATTER_GPU_BENCH_SCENES:-assets/scenes/glass_plate_small.toml assets/scenes/dragon_small.toml}
    cells=assets/scenes/dragon_small.toml
  fi
  local args=("$steps" --agreement)
  for scene in $scenes; do args+=(--scene "$root/$scene"); done
  local log_sim log_render
  log_sim=$(mktemp)
  log_render=$(mktemp)
  echo "== simulation: gpu_steps ${args[*]}"
  "$bin/gpu_steps" "${args[@]}" | tee "$log_sim"
  echo "== tracer"
  # a bound on the tracer's run: a pass that outlasts it still leaves the figures printed before
  local bound=${SHATTER_GPU_BENCH_TRACER_S:-300}
  local particles
  particles=$(trimtope_cells "$bin/shatter" "$cells" "$bin/cells")
  if ! timeout "$bound" "$bin/render" 640 360 --particles "$particles" | tee "$log_render"; then
    echo "gpu-bench: the tracer benchmark stopped after ${bound} s (SHATTER_GPU_BENCH_TRACER_S); figures above are complete"
  fi
  table "$log_sim" "$log_render"
}

# The cells of the scene config $2 (a path from the repository's root, in assets/scenes/) made by
# the shatter binary $1 into the folder $3, with a horizon of 1.5 spacings: the tracer needs the
# cells, and the bonds of the scene's own horizon (123M for dragon_paper) would only cost time.
# Prints the particle file's path.
trimtope_cells() {
  local shatter=$1 scene=$2 out=$3
  sed -e "s#\"\.\./#\"$root/assets/#" -e "s#^output_dir = .*#output_dir = \"$out\"#" \
    -e 's#^horizon_factor = .*#horizon_factor = 1.5#' "$root/$scene" >"$out.toml"
  "$shatter" preprocess --config "$out.toml" >/dev/null 2>&1 || { echo "gpu-bench: could not make the cells of $scene" >&2; exit 1; }
  echo "$out/particles.shp"
}

# The figures above as markdown tables.
table() {
  echo
  echo "== for docs/PERFORMANCE.md ($(date -u +%Y-%m-%d), $(sed -n 's/^GPU steps on \([^:]*\):.*/\1/p' "$1" | head -n 1))"
  echo
  echo "| case | particles | bonds | steps/s | ms/step | x bandwidth floor | CPU agreement |"
  echo "|---|---|---|---|---|---|---|"
  awk '
    function grab(pattern, strip) { if (match($0, pattern)) { v = substr($0, RSTART, RLENGTH); gsub(strip, "", v); return v } return "" }
    function flush() { if (name != "") printf "| %s | %s | %s | %s | %s | %s | %s |\n", name, particles, bonds, rate, ms, floor, agree; name = ""; agree = "" }
    /^\([abc]\) / { flush(); name = $0; sub(/:.*/, "", name); particles = grab("= [0-9]+ particles", "[= a-z]"); bonds = grab("[0-9]+ bonds", "[ a-z]") }
    /^scene / { flush(); name = $2; sub(":", "", name); particles = $3; bonds = grab("[0-9]+ bonds", "[ a-z]") }
    /steps\/s \(/ { rate = $1; ms = grab("[0-9.]+ ms/step", "[ a-z/]") }
    /at the measured copy bandwidth/ { floor = grab("takes [0-9.]+x", "takes ") }
    /CPU agreement/ { agree = $0; sub(/.*\): /, "", agree) }
    END { flush() }
  ' "$1"
  echo
  echo "| elements | tracer | size | M rays/s | against the CPU |"
  echo "|---|---|---|---|---|"
  awk '
    function grab(pattern, strip) { if (match($0, pattern)) { v = substr($0, RSTART, RLENGTH); gsub(strip, "", v); return v } return "" }
    /^render benchmark: [0-9]/ { elements = grab("[0-9]+ [a-z ]+", ""); sub(/ *(of)? *$/, "", elements) }
    /^  (GPU|CPU) / {
      label = $0; sub(/:.*/, "", label); sub(/^  /, "", label); sub(/^GPU .*\), /, "GPU, ", label)
      size = grab("[0-9]+ x [0-9]+ x [0-9]+ spp", ""); rays = grab("[0-9.]+ M rays", " M rays")
      agree = ""; if (index($0, "against the CPU: ")) { agree = $0; sub(/.*against the CPU: /, "", agree) }
      printf "| %s | %s | %s | %s | %s |\n", elements, label, size, rays, agree
    }
  ' "$2"
}

# The paper-scale shots end to end, each bounded; the figures for docs/PERFORMANCE.md#paper-scale-shots.
shots() {
  vulkan
  [ -f "$bench_dir/shatter.gz" ] || { echo "gpu-bench: .gpu-bench/shatter.gz is missing: run '$0 build' first" >&2; exit 1; }
  local bin
  bin=$(mktemp -d)
  gunzip -c "$bench_dir/shatter.gz" >"$bin/shatter"
  chmod +x "$bin/shatter"
  local scenes=${SHATTER_GPU_SHOTS:-assets/scenes/vase_drop_paper.toml assets/scenes/glass_plate_shot_paper.toml assets/scenes/dragon_drop_paper.toml}
  local bound=${SHATTER_GPU_SHOT_S:-300} until=${SHATTER_GPU_SHOT_UNTIL:-rigid}
  local scene log output
  for scene in $scenes; do
    echo "== shot $scene (until $until, at most $bound s)"
    log=$(mktemp)
    local rc=0
    timeout "$bound" "$bin/shatter" run --config "$root/$scene" --until "$until" >"$log" 2>&1 || rc=$?
    if [ "$rc" = 124 ]; then
      echo "gpu-bench: $scene did not finish in $bound s (SHATTER_GPU_SHOT_S); where it got to:"
    elif [ "$rc" != 0 ]; then
      echo "gpu-bench: $scene failed (exit $rc):"
    fi
    # the stage lines, not the progress lines
    grep -v '^\[' "$log" | grep -v '^\s*$' | tail -n 40
    output=$(sed -n 's/^output_dir = "\(.*\)"/\1/p' "$root/$scene")
    if [ -n "$output" ] && [ -f "$(dirname "$root/$scene")/$output/rigid/rigid.checkpoint.shp" ]; then
      "$bin/shatter" inspect "$(dirname "$root/$scene")/$output/rigid/rigid.checkpoint.shp"
    fi
  done
}

case "$mode" in
  build) build ;;
  run) run ;;
  shots) shots ;;
  all) build && run ;;
  *) echo "usage: $0 [all|build|run|shots]" >&2; exit 2 ;;
esac
