#!/usr/bin/env bash
# Takes a fresh Debian 12 machine (root, package registries only) to a working release build of
# splatloop and its Python package. Idempotent: packages already present are skipped, cargo
# rebuilds only what changed.
#
#   bash scripts/setup.sh               the binary and `import splatloop` (about 10 minutes on 2 cores)
#   bash scripts/setup.sh --with-rerun  also rerun recordings (`run --rerun FILE.rrd`): the rerun
#                                       SDK is ~400 crates, about 20 more minutes on 2 cores
set -euo pipefail
cd "$(dirname "$0")/.."

FEATURES=()
for arg in "$@"; do
  case "$arg" in
    --with-rerun) FEATURES=(--features rerun) ;;
    -h|--help) sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "error: unknown option $arg (try --help)" >&2; exit 2 ;;
  esac
done
if [ "${SPLATLOOP_RERUN:-0}" = 1 ]; then FEATURES=(--features rerun); fi

say() { printf '\n==> %s\n' "$*"; }

# System packages:
#   libmujoco-dev           MuJoCo 2.2.2 headers + library (no pkg-config file; build.rs knows)
#   libclang-dev            bindgen parses the MuJoCo and EGL headers with libclang
#   libegl-dev libegl1 libegl-mesa0 libgl1-mesa-dri libgl-dev
#                           headless OpenGL through EGL (device + surfaceless platforms, llvmpipe)
#   mesa-vulkan-drivers libvulkan1
#                           lavapipe, the software Vulkan adapter the wgpu parity tests run on
#   pkg-config python3      build helpers
#   python3-venv            the .venv that holds Ray, the cluster backend of `splatloop sweep`
packages=(
  libmujoco-dev libclang-dev
  libegl-dev libegl1 libegl-mesa0 libgl1-mesa-dri libgl-dev
  mesa-vulkan-drivers libvulkan1
  pkg-config python3 python3-venv ca-certificates
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  say "installing system packages: ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  say "system packages already installed"
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found. Install Rust (rustup, or Debian's cargo) and run this script again." >&2
  exit 1
fi

# Python packages from PyPI into .venv, pinned so every machine runs the same ones:
#   ray      the cluster backend of `splatloop sweep --backend ray` (the sweep finds
#            .venv/bin/python by itself, or SPLATLOOP_PYTHON / --ray-python)
#   mujoco   a current MuJoCo (headers and libmujoco in site-packages/mujoco) that
#            scripts/test.sh also builds and tests against: MUJOCO_DIR takes its folder as it is
#   plyfile  what the reference 3DGS loader reads PLYs with; a test reads map.ply with it
#   rerun-sdk  the rerun viewer and CLI (`.venv/bin/rerun FILE.rrd`), the same version as the
#            Rust SDK that writes our recordings; a test reads one back with `rerun rrd print`
#   maturin, gymnasium, pytest  the Python package `splatloop` (python/): its build backend,
#            the API its environment implements, and its tests
RAY_VERSION=2.40.0
MUJOCO_VERSION=4.0.0
PLYFILE_VERSION=1.1
RERUN_VERSION=0.36.3
MATURIN_VERSION=1.8.3
GYMNASIUM_VERSION=1.0.0
PYTEST_VERSION=8.3.4
if ! .venv/bin/python -c "
import sys, importlib.metadata as m
sys.exit(m.version('ray') != '$RAY_VERSION' or m.version('mujoco') != '$MUJOCO_VERSION' or m.version('plyfile') != '$PLYFILE_VERSION' or m.version('rerun-sdk') != '$RERUN_VERSION' or m.version('maturin') != '$MATURIN_VERSION' or m.version('gymnasium') != '$GYMNASIUM_VERSION' or m.version('pytest') != '$PYTEST_VERSION')" 2>/dev/null; then
  say "installing Ray $RAY_VERSION, MuJoCo $MUJOCO_VERSION, plyfile $PLYFILE_VERSION, rerun-sdk $RERUN_VERSION, maturin, gymnasium and pytest into .venv"
  python3 -m venv .venv
  .venv/bin/pip install --quiet --disable-pip-version-check \
    "ray==$RAY_VERSION" "mujoco==$MUJOCO_VERSION" "plyfile==$PLYFILE_VERSION" "rerun-sdk==$RERUN_VERSION" \
    "maturin==$MATURIN_VERSION" "gymnasium==$GYMNASIUM_VERSION" "pytest==$PYTEST_VERSION"
else
  say "Ray, MuJoCo, plyfile, rerun-sdk, maturin, gymnasium and pytest already in .venv"
fi

say "fetching Rust dependencies"
cargo fetch --locked 2>/dev/null || cargo fetch

# CI sets SPLATLOOP_SKIP_RELEASE_BUILD=1: its tests build the dev profile, and the release
# build alone is a third of a 2-core machine's CI time.
if [ "${SPLATLOOP_SKIP_RELEASE_BUILD:-0}" = 1 ]; then
  say "done (release build skipped: SPLATLOOP_SKIP_RELEASE_BUILD=1; scripts/test.sh installs the Python package from its test build)"
  exit 0
fi

# --with-rerun: `run --rerun FILE.rrd` and `record --rerun` write rerun recordings.
if ((${#FEATURES[@]})); then
  say "building splatloop (release, with rerun recordings)"
else
  say "building splatloop (release; rerun recordings need --with-rerun)"
fi
cargo build --release --locked "${FEATURES[@]}" 2>/dev/null || cargo build --release "${FEATURES[@]}"

# The Python package (`import splatloop`) into .venv. Its crate depends on the same library
# with the same features, so cargo reuses the release build above and compiles only the
# bindings (pyo3, numpy, python/src).
say "installing the Python package splatloop into .venv"
PATH="$PWD/.venv/bin:$PATH" .venv/bin/pip install --quiet --disable-pip-version-check --no-build-isolation ./python

say "done: target/release/splatloop is ready; .venv/bin/python -c 'import splatloop' works"
