#!/usr/bin/env bash
# The preview's benchmark: seconds from an edit to the first broken bond on screen (the preview's
# own count, polled every 50 ms), for each scene given (default: the default pipeline.toml and
# vase_drop_small), EDITS times each (default 3), the edit being a new seed. Uses the release
# build (`cargo build --release` first) and curl; prints one line per edit, for
# docs/PERFORMANCE.md#preview.
#
#   scripts/preview-bench.sh [CONFIG...]
set -euo pipefail
cd "$(dirname "$0")/.."
shatter=${CARGO_TARGET_DIR:-target}/release/shatter
[ -x "$shatter" ] || { echo "preview-bench: build $shatter first (cargo build --release)" >&2; exit 2; }
edits=${EDITS:-3}
port=${PORT:-8790}
configs=("$@")
[ ${#configs[@]} -gt 0 ] || configs=(pipeline.toml assets/scenes/vase_drop_small.toml)

field() {  # field STATE_JSON EXPRESSION: a Python expression over the state `s`
  python3 -c "import json, sys; s = json.loads(sys.argv[1]); print($2)" "$1"
}

for config in "${configs[@]}"; do
  "$shatter" preview --config "$config" --port "$port" >/dev/null &
  server=$!
  trap 'kill $server 2>/dev/null || true' EXIT
  until curl -sf "localhost:$port/api/state" >/dev/null; do sleep 0.1; done
  for seed in $(seq 101 $((100 + edits))); do
    generation=$(curl -sf -X POST "localhost:$port/api/edit" -d "{\"edits\": {\"scene.seed\": $seed}}" |
      python3 -c "import json, sys; print(json.load(sys.stdin)['generation'])")
    while :; do
      state=$(curl -sf "localhost:$port/api/state")
      first=$(field "$state" "s['run']['first_break_s'] if s['run']['generation'] == $generation else None")
      status=$(field "$state" "s['run']['status']")
      if [ "$first" != None ]; then
        echo "$config: run $generation (seed $seed, $(field "$state" "round(s['run']['spacing_m'] * 1000, 2)") mm): first broken bond $first s after the edit"
        break
      fi
      if [ "$status" != running ]; then
        echo "$config: run $generation ended ($status) without a broken bond"
        break
      fi
      sleep 0.05
    done
  done
  kill "$server" 2>/dev/null || true
  wait "$server" 2>/dev/null || true
done
