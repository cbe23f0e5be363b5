#!/usr/bin/env bash
# How far a preview predicts the full resolution's result: for each scene given (default: the
# default pipeline.toml and vase_drop_small), `shatter preview`'s first run to its end, then the
# fragments of its last frame beside those of the scene's own last frame (the scene must have
# been run: `shatter run --until rigid --config CONFIG`). Prints one line per scene, for
# docs/PERFORMANCE.md#preview-against-the-full-resolution. Uses the release build and curl.
#
#   scripts/preview-vs-full.sh [CONFIG...]
set -euo pipefail
cd "$(dirname "$0")/.."
shatter=${CARGO_TARGET_DIR:-target}/release/shatter
[ -x "$shatter" ] || { echo "preview-vs-full: build $shatter first (cargo build --release)" >&2; exit 2; }
port=${PORT:-8791}
configs=("$@")
[ ${#configs[@]} -gt 0 ] || configs=(pipeline.toml assets/scenes/vase_drop_small.toml)

last_fragments() {  # last_fragments OUTPUT_DIR: the shot's last fragments file
  local dir=$1
  if [ -d "$dir/rigid" ] && ls "$dir"/rigid/fragments.*.shp >/dev/null 2>&1; then
    ls "$dir"/rigid/fragments.*.shp | sort | tail -1
  else
    ls "$dir"/fragments/fragments.*.shp | sort | tail -1
  fi
}

figures() {  # figures FRAGMENTS_FILE: elements, fragments, over 1% of the mass, largest share
  "$shatter" inspect "$1" | awk '
    $1 == "elements" { e = $2 } $1 == "fragments" { f = $2 }
    $1 == "fragments_over_1_percent_of_mass" { o = $2 } $1 == "largest_fragment_mass_share" { l = $2 }
    END { printf "%s elements, %s fragments, %s over 1%% of the mass, largest %.1f%%", e, f, o, 100 * l }'
}

for config in "${configs[@]}"; do
  full=$(python3 -c "
import sys, tomllib, pathlib
path = pathlib.Path(sys.argv[1]).resolve()
scene = tomllib.loads(path.read_text())['scene']
print((path.parent / scene['output_dir']).resolve())" "$config")
  full_last=$(last_fragments "$full") || { echo "preview-vs-full: run $config first" >&2; exit 2; }
  "$shatter" preview --config "$config" --port "$port" >/dev/null &
  server=$!
  trap 'kill $server 2>/dev/null || true' EXIT
  until curl -sf "localhost:$port/api/state" >/dev/null; do sleep 0.2; done
  until curl -sf "localhost:$port/api/state" | python3 -c "
import json, sys; run = json.load(sys.stdin)['run']
sys.exit(0 if run and run['status'] == 'finished' else 1 if not run or run['status'] == 'running' else 3)"; do
    [ $? -eq 3 ] && { echo "preview-vs-full: the preview of $config failed" >&2; exit 1; }
    sleep 1
  done
  preview_out=$(ls -d "${TMPDIR:-/tmp}"/shatter-preview-"$server"-*/run-1/out | head -1)
  echo "$config: preview $(figures "$(last_fragments "$preview_out")"); full $(figures "$full_last")"
  kill "$server"
  wait "$server" 2>/dev/null || true
done
