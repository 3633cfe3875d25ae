#!/usr/bin/env bash
# The measurements the open issues need from a hardware GPU, as one script that fits a lent
# machine's few minutes: the splat engines' iteration with both backward kernels (issue 39),
# the apartment's closed loop at 640x480 on the GPU engine (issue 39's real-time factor), and
# what masks cost `record` (issue 41). Each step is under its own time limit and writes its
# output to OUTDIR/<step>.txt, so one that hangs or fails does not take the rest.
#
# On the GPU machine, with the bundle of ../shared/gpu/bundle.sh carried as .gpu:
#   bash .gpu/bench.sh $OUT -- 'bash ../scripts/gpu_checks.sh $OUT'
# (bench.sh runs the command inside .gpu, with $B the bundled binary and the NVIDIA loaders
# set). Here, on any machine: `bash scripts/gpu_checks.sh OUTDIR` with B unset takes
# target/release/splatloop; QUICK=1 shrinks every step to check the script itself.
set -u
out=${1:?usage: gpu_checks.sh OUTDIR}
mkdir -p "$out"
B=${B:-target/release/splatloop}
quick=${QUICK:-0}

step() {
  local name=$1 limit=$2
  shift 2
  echo "=== $name: $*" | tee -a "$out/steps.txt"
  local start end code
  start=$(date +%s.%N)
  timeout "$limit" "$@" >"$out/$name.txt" 2>&1
  code=$?
  end=$(date +%s.%N)
  echo "--- $name: exit $code, $(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f", b - a }') s" |
    tee -a "$out/steps.txt"
}

if [ "$quick" = 1 ]; then
  sizes=10000 iterations=1 budget=4 record=2 pairs=1 resolutions="160x120"
else
  sizes=100000,1000000 iterations=5 budget=60 record=60 pairs=3 resolutions="320x240 640x480"
fi

{ nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null; nproc; } >"$out/machine.txt"

# Issue 39: one iteration of each engine, the GPU's with both backward kernels.
step render 200 "$B" bench render --engine gpu,cpu --gpu-subgroups true,false \
  --gaussians "$sizes" --iterations "$iterations"

# Issue 39: the closed loop at 640x480 on the GPU engine (goal: real-time factor >= 10).
step loop640 150 "$B" run --world worlds/apartment.xml --engine gpu --width 640 --height 480 \
  --budget "$budget" --latency none --test-views 10 --masks false --out /tmp/gpu_checks_loop --overwrite
[ -f /tmp/gpu_checks_loop/metrics.json ] && cp /tmp/gpu_checks_loop/metrics.json "$out/loop640.metrics.json"

# Issue 41: `record` with masks and without, in turn, pair by pair.
for res in $resolutions; do
  w=${res%x*} h=${res#*x}
  for pair in $(seq 1 "$pairs"); do
    for masks in false true; do
      step "record_${res}_masks_${masks}_$pair" 120 "$B" record --world worlds/apartment.xml \
        --duration "$record" --width "$w" --height "$h" --masks "$masks" \
        --out "/tmp/gpu_checks_record_${masks}" --overwrite
    done
  done
done
grep -E "^--- record" "$out/steps.txt" >"$out/record_times.txt"
echo "done: $out"
