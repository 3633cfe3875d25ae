#!/usr/bin/env python3
"""Tables of BENCHMARKS.md's robustness benchmark, from its sweep folders.

The benchmark passes when no episode ends stuck and none has a collision step, in every
condition (as is, and with the sensor perturbed). This reads every finished episode's
metrics.json (WORLD/PLANNER/SEED/metrics.json) of each sweep named and prints Markdown: per
condition and planner the episodes, how many ended stuck, the collision steps, retraces and
recoveries summed, and coverage and PSNR (mean, min); per world and planner the same over its
spawns, one column group per condition; and every episode that failed the benchmark (stuck, a
collision step, or ended by an error), with the `ended` line that says why (or a line saying
there is none).

    python3 scripts/robustness_table.py benchmarks/robustness-as-is benchmarks/robustness-depth-noise \
        --labels "as is,depth noise"
"""

import argparse
import json
import statistics
from pathlib import Path

PLANNERS = ["rtguide", "fbe", "agslam"]
NAMES = {"rtguide": "RT-GuIDE", "fbe": "FBE", "agslam": "AG-SLAM", "survey": "survey"}


def episodes(folder):
    """{(world, planner, seed): metrics} of every finished episode under `folder`."""
    found = {}
    for path in Path(folder).glob("*/*/*/metrics.json"):
        seed, planner, world = path.parent.name, path.parent.parent.name, path.parents[2].name
        if seed.startswith("."):
            continue
        with open(path) as f:
            metrics = json.load(f)
        # An interrupted episode (a sweep stopped by a signal) is not a result: the sweep
        # reruns it, as `splatloop sweep` counts it as not run.
        if metrics.get("ended", "").startswith("interrupted"):
            continue
        found[(world, planner, int(seed))] = metrics
    return found


def stuck(m):
    """Whether the episode ended because the stuck watch gave up on the robot."""
    return m.get("ended", "").startswith("stuck")


def plan_failures(m):
    failures = m.get("plan_failures", {})
    return sum(failures.values()) if isinstance(failures, dict) else int(failures)


def failed(m):
    """Whether the episode fails the benchmark: stuck, any collision step, or ended by an
    error (which `ended` names; the episode's map and metrics are still written)."""
    ended = m.get("ended", "")
    return stuck(m) or m.get("collision_steps", 0) > 0 or ended.startswith("error")


def planner_order(planner):
    return PLANNERS.index(planner) if planner in PLANNERS else len(PLANNERS)


def aggregate(ms):
    """(n, stuck, collision steps, retraces, recoveries, PSNR mean, PSNR min, coverage mean)."""
    psnr = [m["evaluation"]["psnr"] for m in ms]
    coverage = [100.0 * m["evaluation"]["coverage"] for m in ms]
    return (
        len(ms),
        sum(stuck(m) for m in ms),
        sum(m.get("collision_steps", 0) for m in ms),
        sum(m.get("retraces", 0) for m in ms),
        sum(m.get("recovery_events", 0) for m in ms),
        statistics.mean(psnr),
        min(psnr),
        statistics.mean(coverage),
    )


def summary_table(sweeps, labels):
    print("| condition | planner | episodes | stuck | collision steps | retraces | recoveries "
          "| PSNR dB, mean (min) | coverage, mean |")
    print("|---|---|---:|---:|---:|---:|---:|---|---:|")
    for label, found in zip(labels, sweeps):
        planners = sorted({k[1] for k in found}, key=planner_order)
        for planner in planners:
            ms = [m for k, m in found.items() if k[1] == planner]
            n, s, c, r, rec, psnr, low, cov = aggregate(ms)
            print(f"| {label} | {NAMES.get(planner, planner)} | {n} | {s} | {c} | {r} | {rec} "
                  f"| {psnr:.2f} ({low:.2f}) | {cov:.1f}% |")


def world_table(sweeps, labels):
    head = " | ".join(f"{l}: n, stuck, collision steps, retraces, PSNR dB, coverage" for l in labels)
    print(f"| world | planner | {head} |")
    print("|---|---|" + "---|" * len(labels))
    keys = sorted({(k[0], k[1]) for found in sweeps for k in found},
                  key=lambda k: (k[0], planner_order(k[1])))
    for world, planner in keys:
        cells = []
        for found in sweeps:
            ms = [m for k, m in found.items() if k[0] == world and k[1] == planner]
            if not ms:
                cells.append("-")
                continue
            n, s, c, r, _, psnr, _, cov = aggregate(ms)
            cells.append(f"{n}, {s}, {c}, {r}, {psnr:.2f}, {cov:.1f}%")
        print(f"| {world} | {NAMES.get(planner, planner)} | " + " | ".join(cells) + " |")


def failures(sweeps, labels):
    bad = [(label, key, m) for label, found in zip(labels, sweeps)
           for key, m in sorted(found.items(), key=lambda i: (i[0][0], planner_order(i[0][1]), i[0][2]))
           if failed(m)]
    if not bad:
        total = sum(len(found) for found in sweeps)
        print(f"No episode of the {total} ended stuck or by an error, or had a collision step.")
        return
    print("| condition | world | planner | spawn | collision steps | ended |")
    print("|---|---|---|---:|---:|---|")
    for label, (world, planner, seed), m in bad:
        print(f"| {label} | {world} | {NAMES.get(planner, planner)} | {seed} "
              f"| {m.get('collision_steps', 0)} | {m.get('ended', '')} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sweeps", nargs="+", help="sweep folders, one per condition")
    parser.add_argument("--labels", help="the conditions' names, comma-separated "
                        "(default: the folders' names)")
    args = parser.parse_args()
    labels = args.labels.split(",") if args.labels else [Path(s).name for s in args.sweeps]
    if len(labels) != len(args.sweeps):
        parser.error(f"{len(labels)} labels for {len(args.sweeps)} sweeps")
    sweeps = []
    for folder in args.sweeps:
        if not Path(folder).is_dir():
            parser.error(f"{folder} is not a folder: name a sweep's --out")
        sweeps.append(episodes(folder))
    if not any(sweeps):
        parser.error("no finished episode (WORLD/PLANNER/SEED/metrics.json) in the folders named")
    summary_table(sweeps, labels)
    print()
    world_table(sweeps, labels)
    print()
    failures(sweeps, labels)


if __name__ == "__main__":
    main()
