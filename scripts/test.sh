#!/usr/bin/env bash
# The tests, as CI runs them: formatting, then every test of the workspace against Debian's
# MuJoCo 2.2.2, the rerun recording test, and the MuJoCo-version tests (depth against mj_ray,
# the dataset round trip) against the pip MuJoCo that scripts/setup.sh installs into .venv.
# Every build of our crates is linted by clippy with warnings denied, the rerun feature's code
# included.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo fmt --all --check

# Clippy as the compiler of our crates (what `cargo clippy` does, but with code generation):
# the test builds are the lint, so nothing is checked twice. rerun's SDK alone is about 400
# crates, and a separate `cargo clippy --features rerun` would check all of them again, which
# on 2 cores costs more than CI's time allows.
RUSTC_WORKSPACE_WRAPPER="$(command -v clippy-driver)" || {
  echo "error: clippy-driver not found; install clippy (rustup component add clippy)" >&2
  exit 1
}
export RUSTC_WORKSPACE_WRAPPER
export CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"

# Every test binary runs through scripts/crash_backtrace.sh: a test process that a crash in C
# kills (MuJoCo, Mesa, EGL; once seen as a bare "signal: 11") prints each thread's backtrace.
# Only where gdb can start a program and report its exit status (a sandbox may forbid ptrace).
if gdb_status=$(gdb -q -batch -return-child-result -ex run --args sh -c 'exit 7' >/dev/null 2>&1; echo $?) &&
  [ "$gdb_status" = 7 ]; then
  host=$(rustc -vV | sed -n 's/^host: //p')
  runner_var="CARGO_TARGET_$(echo "$host" | tr '[:lower:]-' '[:upper:]_')_RUNNER"
  export "$runner_var=$PWD/scripts/crash_backtrace.sh"
else
  echo "note: gdb cannot run programs here; a crashing test will show no backtrace" >&2
fi

cargo test --workspace

# The Python package from the test build's artefacts (the dev profile is optimised), into
# .venv, then its tests; the dataset test calls the binary cargo test just built.
echo "==> the Python package (pytest)"
VIRTUAL_ENV="$PWD/.venv" PATH="$PWD/.venv/bin:$PATH" .venv/bin/maturin develop --quiet -m python/Cargo.toml
.venv/bin/python -m pytest -q python/tests

# Its own profile (Cargo.toml's recording-test): rerun's SDK unoptimised, which keeps this
# build to minutes on 2 cores; the recording is read back by .venv's rerun CLI.
echo "==> the rerun recording test"
cargo test --profile recording-test --features rerun --test host -- recording::

pip_mujoco=$(.venv/bin/python -c 'import mujoco, os; print(os.path.dirname(mujoco.__file__))' 2>/dev/null) || {
  echo "error: no pip MuJoCo in .venv; run scripts/setup.sh first" >&2
  exit 1
}
# The same target folder: only the host crate is rebuilt for another MuJoCo (build.rs reruns
# when MUJOCO_DIR changes), which keeps CI well under 30 minutes; the next plain build switches
# back the same way.
echo "==> sensor and dataset tests against MuJoCo from $pip_mujoco"
MUJOCO_DIR="$pip_mujoco" cargo test --test host -- sensor:: dataset::
