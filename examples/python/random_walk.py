"""A random-walk policy in splatloop's closed loop: 30 think periods of random [v, w], then the
episode folder written as `splatloop run` writes it.

    .venv/bin/python examples/python/random_walk.py runs/random-walk
"""

import sys

import numpy as np

import splatloop

out = sys.argv[1] if len(sys.argv) > 1 else "runs/random-walk"
env = splatloop.Env(world="worlds/room.xml", latency="none", budget=30, out=out)
obs, info = env.reset(seed=1)
rng = np.random.default_rng(1)
total = 0.0
while True:
    action = env.action_space.sample() if rng.random() < 0.8 else np.array([0.0, 0.5], np.float32)
    obs, reward, terminated, truncated, info = env.step(action)
    total += reward
    if terminated or truncated:
        break
print(f"t = {info['time']:.0f} s: coverage {100 * info['coverage']:.1f}%, reward {total:.3f}, {info['gaussians']} Gaussians")
metrics = env.write()
print(f"wrote {out}: PSNR {metrics['evaluation']['psnr']:.1f} dB on the hidden views")
env.close()
