#!/usr/bin/env bash
# The README's test command. Installs what the tests need where it is missing, then runs every
# test of the workspace (arguments go to `cargo test`):
#   - Mesa's lavapipe (a software Vulkan device) and the Vulkan loader: every GPU kernel runs;
#   - a C++ compiler: NVIDIA FLIP (the regression images' metric) builds from source;
#   - Pixar's usd-core (Python): the USD files post and rigid write are parsed by USD itself;
#   - Blender (Debian's): a rendered frame's passes are read by Blender's compositor;
#   - Chromium and ChromeDriver (Debian's): `shatter preview`'s page runs in a headless browser;
#   - a Rust toolchain (rustup), when cargo is missing.
# It installs with apt-get and pip (Debian or Ubuntu; as root or through sudo). Elsewhere it names
# what is missing and how to get it, and stops.
#
#   scripts/test.sh                 # install what is missing, then cargo test --workspace --locked
#   scripts/test.sh --setup-only    # install what is missing, run nothing
set -euo pipefail
cd "$(dirname "$0")/.."

setup_only=false
if [ "${1:-}" = "--setup-only" ]; then
  setup_only=true
  shift
fi

if [ "$(id -u)" = 0 ]; then sudo=""; else sudo="sudo"; fi

# The Debian packages whose files the tests need, each with the file that shows it is there.
missing_packages=()
need_package() {  # need_package PACKAGE TEST...
  local package=$1
  shift
  "$@" >/dev/null 2>&1 || missing_packages+=("$package")
}
need_package mesa-vulkan-drivers sh -c 'ls /usr/share/vulkan/icd.d/lvp_icd*.json'
need_package libvulkan1 sh -c 'ldconfig -p | grep -q "libvulkan.so.1 "'
need_package g++ command -v c++
need_package ca-certificates test -d /etc/ssl/certs
need_package curl command -v curl
need_package python3-pip sh -c 'python3 -m pip --version || python3 -c "import pxr"'
need_package blender command -v blender
need_package chromium test -x /usr/bin/chromium
need_package chromium-driver command -v chromedriver

if [ ${#missing_packages[@]} -gt 0 ]; then
  if ! command -v apt-get >/dev/null 2>&1; then
    echo "error: the tests need ${missing_packages[*]} (Debian's names): install them with your" \
      "system's package manager, then run scripts/test.sh again" >&2
    exit 2
  fi
  echo "installing ${missing_packages[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -q
  $sudo apt-get install -y -q --no-install-recommends "${missing_packages[@]}"
fi

if ! python3 -c "import pxr" >/dev/null 2>&1; then
  echo "installing usd-core (pip)"
  python3 -m pip install --quiet usd-core \
    || python3 -m pip install --quiet --break-system-packages usd-core
fi

if ! command -v cargo >/dev/null 2>&1; then
  if [ ! -x "$HOME/.cargo/bin/cargo" ]; then
    echo "installing Rust (rustup)"
    curl -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal --component rustfmt,clippy
  fi
  # shellcheck disable=SC1091
  . "$HOME/.cargo/env"
fi

# Mesa's device-select Vulkan layer prints an error when a headless machine has no
# XDG_RUNTIME_DIR; it chooses nothing on a lavapipe-only machine, so leave it out of the logs.
export NODEVICE_SELECT=1

if [ "$setup_only" = true ]; then
  exit 0
fi
cargo test --workspace --locked "$@"
