"""A recorded dataset as a PyTorch DataLoader, read in place (no copy of the folder).

    target/release/splatloop record --out runs/record
    .venv/bin/python examples/python/dataloader.py runs/record
"""

import sys

import numpy as np

import splatloop

path = sys.argv[1] if len(sys.argv) > 1 else "runs/record"
dataset = splatloop.Dataset(path)
print(f"{len(dataset)} frames; the first at t = {dataset[0]['timestamp']:.2f} s, K =\n{dataset[0]['K']}")
try:
    import torch
    from torch.utils.data import DataLoader, Dataset

    class Frames(Dataset):
        def __len__(self):
            return len(dataset)

        def __getitem__(self, i):
            f = dataset[i]
            return torch.from_numpy(f["rgb"]), torch.from_numpy(f["depth"]), torch.from_numpy(f["pose"])

    for rgb, depth, pose in DataLoader(Frames(), batch_size=8, shuffle=True):
        print(rgb.shape, depth.shape, pose.shape)
        break
except ImportError:
    depths = np.stack([dataset[i]["depth"] for i in range(min(8, len(dataset)))])
    print(f"(no PyTorch here) a batch of depth as numpy: {depths.shape}, mean {depths[depths > 0].mean():.2f} m")
