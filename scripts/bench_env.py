"""Wall time of the 60 s room episode stepped from Python (BENCHMARKS.md, "Python: an episode
stepped from splatloop.Env"): the episode of
`splatloop run --budget 60 --latency none --engine cpu --seed 3`, with the built-in planner
deciding (`env.step(None)`), timed from the constructor to `write`.

    .venv/bin/python scripts/bench_env.py OUT [TEST_VIEWS]
"""

import sys
import time

import splatloop


def main() -> None:
    out = sys.argv[1]
    views = int(sys.argv[2]) if len(sys.argv) > 2 else 100
    start = time.perf_counter()
    env = splatloop.Env(
        world="worlds/room.xml",
        latency="none",
        budget=60,
        engine="cpu",
        seed=3,
        test_views=views,
        out=out,
    )
    env.reset(seed=3)
    while True:
        _, _, terminated, truncated, _ = env.step(None)
        if terminated or truncated:
            break
    metrics = env.write()
    print(f"python wall {time.perf_counter() - start:.2f} s, {metrics['gaussians']} Gaussians")


if __name__ == "__main__":
    main()
