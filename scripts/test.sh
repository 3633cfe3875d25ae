#!/usr/bin/env bash
# The tests, as CI runs them: formatting and lints, every test of the workspace against
# Debian's MuJoCo 2.2.2, then the MuJoCo-version tests (depth against mj_ray, the dataset round
# trip) against the pip MuJoCo that scripts/setup.sh installs into .venv.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo fmt --all --check
cargo clippy --all-targets -- -D warnings
cargo test --workspace

pip_mujoco=$(.venv/bin/python -c 'import mujoco, os; print(os.path.dirname(mujoco.__file__))' 2>/dev/null) || {
  echo "error: no pip MuJoCo in .venv; run scripts/setup.sh first" >&2
  exit 1
}
# The same target folder: only the host crate is rebuilt for another MuJoCo (build.rs reruns
# when MUJOCO_DIR changes), which keeps CI well under 30 minutes; the next plain build switches
# back the same way.
echo "==> sensor and dataset tests against MuJoCo from $pip_mujoco"
MUJOCO_DIR="$pip_mujoco" cargo test --test host -- sensor:: dataset::
