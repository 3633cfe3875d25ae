#!/usr/bin/env bash
# Cargo's runner for the test binaries (scripts/test.sh sets it): runs one under gdb, so that a
# test process killed by a signal (a crash in C: MuJoCo, Mesa, EGL) prints every thread's
# backtrace before the run fails, instead of only "signal: 11". The exit status is the test
# binary's own (255 when a signal killed it). Without gdb, the binary runs as is.
set -euo pipefail
if ! command -v gdb >/dev/null 2>&1; then
  exec "$@"
fi
exec gdb -q -batch -return-child-result \
  -ex "set print thread-events off" \
  -ex "set print inferior-events off" \
  -ex "set disable-randomization off" \
  -ex "handle SIGPIPE nostop noprint pass" \
  -ex run \
  -ex "thread apply all bt 25" \
  --args "$@"
