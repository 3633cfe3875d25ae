#!/usr/bin/env python3
"""Tables of BENCHMARKS.md's comparison under both protocols, from two sweep folders.

Reads every finished episode's metrics.json (WORLD/PLANNER/SEED/metrics.json) of the old
protocol's sweep (each planner ends when it is done) and the new one's (every planner runs to
the same simulated time), and prints three Markdown tables: each episode under both; per world
and spawn the differences RT-GuIDE minus the survey and minus FBE (PSNR, coverage), old beside
new, with their means over the pairs both sweeps have; and, from the new sweep's
`psnr_over_time` (PSNR on a subsample of the hidden views), each planner's PSNR at a third,
two thirds and the whole of the common budget, the comparison at equal times.

    python3 scripts/comparison_table.py benchmarks/comparison-spawns benchmarks/comparison-fair

Two sweeps of the same protocol that differ in one planner's option compare the same way: name
the columns, keep the rows of the planners that changed, and take the differences against them:

    python3 scripts/comparison_table.py benchmarks/comparison-fair benchmarks/comparison-joined \
        --labels "papers' clusters,joined" --planners fbe,agslam --against fbe,agslam
"""

import argparse
import json
import statistics
import sys
from pathlib import Path

PLANNERS = ["survey", "rtguide", "fbe", "agslam"]
NAMES = {"survey": "survey", "rtguide": "RT-GuIDE", "fbe": "FBE", "agslam": "AG-SLAM"}


def episodes(folder):
    """{(world, planner, seed): metrics} of every finished episode under `folder`."""
    found = {}
    for path in Path(folder).glob("*/*/*/metrics.json"):
        seed, planner, world = path.parent.name, path.parent.parent.name, path.parents[2].name
        if seed.startswith("."):
            continue
        with open(path) as f:
            found[(world, planner, int(seed))] = json.load(f)
    return found


def figures(m):
    """(simulated s, mapping steps, PSNR dB, coverage %) of one episode."""
    e = m.get("evaluation", {})
    return (m["simulated_seconds"], m["mapping_steps"], e["psnr"], 100.0 * e["coverage"])


def order(key):
    world, planner, seed = key
    return (world, PLANNERS.index(planner) if planner in PLANNERS else 99, seed)


def episode_table(old, new, labels, planners):
    a, b = labels
    print(f"| world | planner | spawn | {a}: sim s, mapping steps | {a} PSNR dB | {a} coverage "
          f"| {b}: sim s, mapping steps | {b} PSNR dB | {b} coverage | {b} ended |")
    print("|---|---|---:|---|---:|---:|---|---:|---:|---|")
    for key in sorted(new, key=order):
        world, planner, seed = key
        if planner not in planners:
            continue
        n = figures(new[key])
        o = figures(old[key]) if key in old else None
        old_cells = (f"{o[0]:.0f}, {o[1]} | {o[2]:.2f} | {o[3]:.1f}%" if o else "- | - | -")
        print(f"| {world} | {planner} | {seed} | {old_cells} | {n[0]:.0f}, {n[1]} | {n[2]:.2f} "
              f"| {n[3]:.1f}% | {new[key].get('ended', '')} |")


def difference(runs, world, seed, other):
    a, b = runs.get((world, "rtguide", seed)), runs.get((world, other, seed))
    if a is None or b is None:
        return None
    fa, fb = figures(a), figures(b)
    return (fa[2] - fb[2], fa[3] - fb[3])


def difference_table(old, new, labels, against):
    a, b = labels
    print("| world | spawn | " + " | ".join(
        f"RT-GuIDE - {NAMES[o]}, {a}: dB, cov pts | {b}: dB, cov pts" for o in against)
        + " |")
    print("|---|---:|" + "---|---|" * len(against))
    pairs = sorted({(w, s) for (w, p, s) in new if p == "rtguide"})
    # Per column (planner, sweep): the differences of the pairs both sweeps have.
    columns = {(o, which): [] for o in against for which in (0, 1)}
    for world, seed in pairs:
        cells = []
        for other in against:
            for which, (runs, rest) in enumerate(((old, new), (new, old))):
                d = difference(runs, world, seed, other)
                cells.append(f"{d[0]:+.2f}, {d[1]:+.1f}" if d else "-")
                if d and difference(rest, world, seed, other):
                    columns[(other, which)].append(d)
        print(f"| {world} | {seed} | " + " | ".join(cells) + " |")

    def mean(ds):
        if not ds:
            return "-"
        return (f"{statistics.mean(d[0] for d in ds):+.2f}, "
                f"{statistics.mean(d[1] for d in ds):+.1f} (n = {len(ds)})")

    print("| mean over the pairs both sweeps have | | " + " | ".join(
        mean(columns[(o, which)]) for o in against for which in (0, 1)) + " |")


def psnr_at(series, t):
    """The last PSNR of `series` ([time, dB] pairs) taken at or before `t`."""
    taken = [v for (time, v) in series if time <= t + 1e-6]
    return taken[-1] if taken else None


def equal_times_table(new):
    print("| world | spawn | " + " | ".join(
        f"{p}: 1/3, 2/3, end dB" for p in PLANNERS) + " |")
    print("|---|---:|" + "---|" * len(PLANNERS))
    means = {p: [[], [], []] for p in PLANNERS}
    for world, seed in sorted({(w, s) for (w, p, s) in new}):
        runs = [new.get((world, p, seed)) for p in PLANNERS]
        if any(r is None or not r.get("psnr_over_time") for r in runs):
            continue
        cells = []
        for p, m in zip(PLANNERS, runs):
            budget = m["simulated_seconds"]
            values = [psnr_at(m["psnr_over_time"], f * budget) for f in (1 / 3, 2 / 3, 1.0)]
            for k, v in enumerate(values):
                means[p][k].append(v)
            cells.append(", ".join(f"{v:.2f}" for v in values))
        print(f"| {world} | {seed} | " + " | ".join(cells) + " |")
    n = len(means[PLANNERS[0]][0])
    if n:
        print("| mean | | " + " | ".join(
            ", ".join(f"{statistics.mean(means[p][k]):.2f}" for k in range(3)) for p in PLANNERS)
            + f" (n = {n}) |")


def names(text, allowed=None):
    """A comma-separated list; with `allowed`, every name must be one of them."""
    items = [t.strip() for t in text.split(",") if t.strip()]
    unknown = [t for t in items if allowed is not None and t not in allowed]
    if unknown:
        raise argparse.ArgumentTypeError(
            f"unknown planner(s) {', '.join(unknown)}; choose from {', '.join(allowed)}")
    return items


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("old", help="the first sweep's folder (WORLD/PLANNER/SEED/metrics.json)")
    parser.add_argument("new", help="the second sweep's folder")
    parser.add_argument("--labels", type=names, default=["old", "new"],
                        help="the two sweeps' names in the column heads (default: old,new)")
    parser.add_argument("--planners", type=lambda t: names(t, PLANNERS), default=PLANNERS,
                        help="the planners whose episodes the first table lists (default: all)")
    parser.add_argument("--against", type=lambda t: names(t, PLANNERS), default=["survey", "fbe"],
                        help="RT-GuIDE's differences are taken against these (default: survey,fbe)")
    args = parser.parse_args()
    if len(args.labels) != 2:
        parser.error("--labels takes two names, the first sweep's and the second's")
    old, new = episodes(args.old), episodes(args.new)
    if not new:
        sys.exit(f"no finished episode (*/*/*/metrics.json) under {args.new}")
    episode_table(old, new, args.labels, args.planners)
    print()
    difference_table(old, new, args.labels, args.against)
    print()
    equal_times_table(new)


if __name__ == "__main__":
    main()
