#!/usr/bin/env bash
# The tests, as CI runs them: formatting and lints (with and without the rerun feature), every
# test of the workspace against Debian's MuJoCo 2.2.2, the rerun recording test, then the
# MuJoCo-version tests (depth against mj_ray, the dataset round trip) against the pip MuJoCo
# that scripts/setup.sh installs into .venv.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo fmt --all --check
# Lints under Cargo.toml's recording-test profile (dependencies unoptimised): rerun's SDK is
# about 400 crates, and this profile's build scripts and proc macros are the ones the recording
# test below reuses. The second run re-checks only our crates without the feature.
cargo clippy --profile recording-test --all-targets --features rerun -- -D warnings
cargo clippy --profile recording-test --all-targets -- -D warnings
cargo test --workspace

# The recording is read back by .venv's rerun CLI.
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
