#!/usr/bin/env bash
# Shows that a change leaves every output byte-identical: builds BASE (a commit) and the working
# tree (or, with --head REV, the commit REV) as release binaries, runs each scene end to end with
# both on the CPU backend, and compares every file the two runs write. A refactor's proof.
#
#   scripts/check-unchanged.sh BASE [--head REV] [SCENE.toml ...]
#
# The scenes default to pipeline.toml and every assets/scenes/*_small.toml. Each side runs its own
# tree's scenes and assets, copied to target/unchanged/<side>/ so that the runs write there and
# never into out/. The output folder's lock is left out of the comparison (it names the process
# that held it). Exits 0 when every scene's outputs match, 1 when any differs (naming the files).
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD

usage() {
  echo "usage: scripts/check-unchanged.sh BASE [--head REV] [SCENE.toml ...]" >&2
  exit 2
}
commit() {
  git rev-parse --quiet --verify "$1^{commit}" || { echo "error: $1 is not a commit" >&2; exit 2; }
}
[ $# -ge 1 ] || usage
base=$(commit "$1")
shift
head=""
if [ "${1:-}" = "--head" ]; then
  [ $# -ge 2 ] || usage
  head=$(commit "$2")
  shift 2
fi
if [ $# -gt 0 ]; then
  scenes=("$@")
else
  scenes=(pipeline.toml assets/scenes/*_small.toml)
fi

work=$repo/target/unchanged
mkdir -p "$work"

# Builds the tree at $2 as side $1 and copies its binary to $work/shatter-$1. Each side has its own
# target folder: cargo hashes a workspace's crates by their paths within it, so two trees sharing
# one folder share their artifacts, and a tree whose files are older than the other's build would
# be taken as built and get the other's binary.
build() {
  CARGO_TARGET_DIR=$work/target-$1 cargo build --release --locked --quiet --manifest-path "$2/Cargo.toml"
  cp "$work/target-$1/release/shatter" "$work/shatter-$1"
}

# Lays out side $1 from tree $2: its scenes and assets, outputs empty.
lay_out() {
  rm -rf "${work:?}/$1"
  mkdir -p "$work/$1"
  cp -r "$2/assets" "$2/pipeline.toml" "$work/$1/"
}

# Checks out commit $2 in worktree $1.
check_out() {
  if [ -e "$1/.git" ]; then
    git -C "$1" checkout --detach --quiet "$2"
  else
    git worktree add --detach --force "$1" "$2" >/dev/null
  fi
}

check_out "$work/base-src" "$base"
head_tree=$repo
if [ -n "$head" ]; then
  check_out "$work/head-src" "$head"
  head_tree=$work/head-src
fi
echo "building $base and ${head:-the working tree} (release)"
build base "$work/base-src"
build head "$head_tree"
if cmp -s "$work/shatter-base" "$work/shatter-head"; then
  # each binary's debug info holds its tree's path, so two real builds never give the same file
  echo "error: the two builds gave the same binary; remove $work and run again" >&2
  exit 2
fi
lay_out base "$work/base-src"
lay_out head "$head_tree"

status=0
for scene in "${scenes[@]}"; do
  for side in base head; do
    (cd "$work/$side" && "$work/shatter-$side" run --config "$scene" --backend cpu >"$work/$side.log" 2>&1) || {
      echo "$scene: the $side binary failed (log: $work/$side.log)" >&2
      status=1
      rm -rf "$work/base/out" "$work/head/out"
      continue 2
    }
  done
  differing=$(diff -r -q -x shatter.lock "$work/base/out" "$work/head/out" || true)
  if [ -n "$differing" ]; then
    echo "$scene: outputs differ:"
    echo "$differing"
    status=1
  else
    echo "$scene: $(find "$work/head/out" -type f | wc -l) files byte-identical"
  fi
  rm -rf "$work/base/out" "$work/head/out"
done
exit $status
