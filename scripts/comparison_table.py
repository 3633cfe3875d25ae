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
"""

import json
import statistics
import sys
from pathlib import Path

PLANNERS = ["survey", "rtguide", "fbe", "agslam"]


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


def episode_table(old, new):
    print("| world | planner | spawn | old: sim s, mapping steps | old PSNR dB | old coverage "
          "| new: sim s, mapping steps | new PSNR dB | new coverage | new ended |")
    print("|---|---|---:|---|---:|---:|---|---:|---:|---|")
    for key in sorted(new, key=order):
        world, planner, seed = key
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


def difference_table(old, new):
    print("| world | spawn | RT-GuIDE - survey, old: dB, cov pts | new: dB, cov pts "
          "| RT-GuIDE - FBE, old: dB, cov pts | new: dB, cov pts |")
    print("|---|---:|---|---|---|---|")
    pairs = sorted({(w, s) for (w, p, s) in new if p == "rtguide"})
    columns = {k: [] for k in ("os", "ns", "of", "nf")}
    for world, seed in pairs:
        cells = []
        for tag, runs, other in (("os", old, "survey"), ("ns", new, "survey"),
                                 ("of", old, "fbe"), ("nf", new, "fbe")):
            d = difference(runs, world, seed, other)
            cells.append(f"{d[0]:+.2f}, {d[1]:+.1f}" if d else "-")
            if d and difference(old if tag[0] == "n" else new, world, seed, other):
                columns[tag].append(d)
        print(f"| {world} | {seed} | " + " | ".join(cells) + " |")

    def mean(ds):
        if not ds:
            return "-"
        return (f"{statistics.mean(d[0] for d in ds):+.2f}, "
                f"{statistics.mean(d[1] for d in ds):+.1f} (n = {len(ds)})")

    print(f"| mean over the pairs both sweeps have | | {mean(columns['os'])} | {mean(columns['ns'])} "
          f"| {mean(columns['of'])} | {mean(columns['nf'])} |")


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


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: comparison_table.py OLD_SWEEP_FOLDER NEW_SWEEP_FOLDER")
    old, new = episodes(sys.argv[1]), episodes(sys.argv[2])
    if not new:
        sys.exit(f"no finished episode (*/*/*/metrics.json) under {sys.argv[2]}")
    episode_table(old, new)
    print()
    difference_table(old, new)
    print()
    equal_times_table(new)


if __name__ == "__main__":
    main()
