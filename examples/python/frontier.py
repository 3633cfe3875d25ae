"""A frontier planner written in Python (numpy only), in splatloop's closed loop.

It keeps its own 2D grid from the depth frames (free along each ray, occupied where a return
lands between ankle and head height), finds the frontier cells (known free beside unknown),
and drives toward the nearest one it can reach through free space, one think period at a time.
When no frontier is reachable it says so: the robot then idles while the mapper goes on to
the budget (or the episode ends there, with `stop_when_done=True`).

Run it on its own:

    .venv/bin/python examples/python/frontier.py runs/py-frontier

or beside ours in a sweep (the same table, its rows named python-FrontierPlanner):

    target/release/splatloop sweep --worlds worlds/room.xml \\
        --planners fbe,rtguide,python:examples/python/frontier.py:FrontierPlanner \\
        --seeds 1..2 --budget 60 --latency none --out runs/py-sweep
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

CELL = 0.1  # metres per grid cell
SIZE = 400  # cells a side: 40 m, centred on the world's origin
UNKNOWN, FREE, OCCUPIED = 0, 1, 2
OBSTACLE_HEIGHTS = (0.06, 1.2)  # a return between these heights (metres) is an obstacle
CLEARANCE = 0.45  # metres kept from obstacles (the robot's 0.3 m radius and a margin)
MAX_FORWARD, MAX_TURN = 0.5, 0.9  # within the drive's limits (0.6 m/s, 0.9 rad/s)
LOOK_AROUND = 7  # think periods spent turning in place at the start (one full turn)
PIXEL_STRIDE = 6  # every 6th pixel of each 6th row
BLIND = 1.0  # metres around the robot where frontiers are ignored (the floor it cannot see)


class FrontierPlanner:
    """Nearest reachable frontier, on a grid of its own made from the depth frames."""

    def __init__(self):
        self.grid = np.zeros((SIZE, SIZE), np.uint8)
        self.plans = 0

    # --- the grid -------------------------------------------------------------------------

    @staticmethod
    def cell(x, y):
        """Grid indices of world points (arrays or scalars)."""
        return (np.floor(np.asarray(x) / CELL).astype(int) + SIZE // 2,
                np.floor(np.asarray(y) / CELL).astype(int) + SIZE // 2)

    def observe(self, frame, map):
        # Where the robot stands is free.
        x, y, _ = frame["robot"]
        i, j = self.cell(x, y)
        r = 2
        patch = self.grid[i - r:i + r + 1, j - r:j + r + 1]
        patch[patch == UNKNOWN] = FREE
        depth = frame["depth"][::PIXEL_STRIDE, ::PIXEL_STRIDE]
        K, pose = frame["K"], frame["pose"]
        rows, cols = np.nonzero(depth > 0)
        z = depth[rows, cols].astype(np.float64)
        u, v = cols * PIXEL_STRIDE, rows * PIXEL_STRIDE
        camera = np.stack([(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, z])
        world = pose[:3, :3] @ camera + pose[:3, 3:4]
        origin = pose[:3, 3]
        # Free along each ray in the plane, up to the return.
        dx, dy = world[0] - origin[0], world[1] - origin[1]
        reach = np.hypot(dx, dy)
        steps = np.arange(0.0, 1.0, CELL / 2 / max(reach.max(initial=CELL), CELL))
        fx = origin[0] + np.outer(steps, dx)
        fy = origin[1] + np.outer(steps, dy)
        keep = np.outer(steps, reach) < reach - CELL
        i, j = self.cell(fx[keep], fy[keep])
        inside = (i >= 0) & (i < SIZE) & (j >= 0) & (j < SIZE)
        free = self.grid[i[inside], j[inside]] != OCCUPIED
        self.grid[i[inside][free], j[inside][free]] = FREE
        # Obstacles where a return lands at obstacle height; the floor is free.
        low, high = OBSTACLE_HEIGHTS
        i, j = self.cell(world[0], world[1])
        inside = (i >= 0) & (i < SIZE) & (j >= 0) & (j < SIZE)
        obstacle = inside & (world[2] > low) & (world[2] < high)
        floor = inside & (world[2] <= low)
        self.grid[i[floor], j[floor]] = np.where(self.grid[i[floor], j[floor]] == OCCUPIED, OCCUPIED, FREE)
        self.grid[i[obstacle], j[obstacle]] = OCCUPIED

    def traversable(self):
        """Free cells at least CLEARANCE from every obstacle."""
        occupied = self.grid == OCCUPIED
        r = int(math.ceil(CLEARANCE / CELL))
        blocked = np.zeros_like(occupied)
        for di in range(-r, r + 1):
            for dj in range(-r, r + 1):
                if di * di + dj * dj <= r * r:
                    blocked |= np.roll(np.roll(occupied, di, 0), dj, 1)
        return (self.grid == FREE) & ~blocked

    def frontiers(self):
        """Free cells with an unknown 4-neighbour."""
        unknown = self.grid == UNKNOWN
        beside = np.zeros_like(unknown)
        for axis in (0, 1):
            for shift in (-1, 1):
                beside |= np.roll(unknown, shift, axis)
        return (self.grid == FREE) & beside

    # --- planning -------------------------------------------------------------------------

    def plan(self, observation, map):
        self.plans += 1
        x, y, theta = observation["start"]
        if self.plans <= LOOK_AROUND:
            return {"commands": [(0.0, MAX_TURN)], "period": 1.0}
        path = self.path_to_nearest_frontier(x, y)
        if path is None:
            return "no reachable frontier left"
        # Steer toward a point about 0.6 m along the path.
        gx, gy = path[min(len(path) - 1, 6)]
        error = math.remainder(math.atan2(gy - y, gx - x) - theta, math.tau)
        w = float(np.clip(1.5 * error, -MAX_TURN, MAX_TURN))
        v = MAX_FORWARD * max(0.0, math.cos(error)) ** 2 if abs(error) < 0.6 else 0.0
        return {"commands": [(v, w)], "period": 1.0}

    def path_to_nearest_frontier(self, x, y):
        """Cell centres from the robot to the nearest frontier reachable through traversable
        cells (breadth first), or None."""
        walk = self.traversable()
        targets = self.frontiers()
        si, sj = (int(c) for c in self.cell(x, y))
        if not walk[si, sj]:
            # Inside an obstacle's clearance: let it leave through the free cells around it.
            r = int(math.ceil((CLEARANCE + 0.2) / CELL))
            near = self.grid[si - r:si + r + 1, sj - r:sj + r + 1] == FREE
            walk[si - r:si + r + 1, sj - r:sj + r + 1] |= near
            walk[si, sj] = True
        # The camera never sees the floor within about 0.7 m of the robot: frontiers there are
        # its blind spot, not unexplored space.
        blind = int(math.ceil(BLIND / CELL))
        parent = {(si, sj): None}
        queue = deque([(si, sj)])
        found = None
        while queue:
            i, j = queue.popleft()
            near_target = targets[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2].any()
            if near_target and (i - si) ** 2 + (j - sj) ** 2 > blind * blind:
                found = (i, j)
                break
            for ni, nj in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
                if 0 <= ni < SIZE and 0 <= nj < SIZE and walk[ni, nj] and (ni, nj) not in parent:
                    parent[(ni, nj)] = (i, j)
                    queue.append((ni, nj))
        if found is None:
            return None
        cells = []
        while found is not None:
            cells.append(found)
            found = parent[found]
        cells.reverse()
        return [((i - SIZE // 2 + 0.5) * CELL, (j - SIZE // 2 + 0.5) * CELL) for i, j in cells]


if __name__ == "__main__":
    import sys

    import splatloop

    out = sys.argv[1] if len(sys.argv) > 1 else "runs/py-frontier"
    planner = FrontierPlanner()
    metrics = splatloop.run(planner, out=out, world="worlds/room.xml", latency="none", budget=60, overwrite=True)
    evaluation = metrics["evaluation"]
    print(
        f"{metrics['ended']} at {metrics['simulated_seconds']:.0f} s: coverage {100 * evaluation['coverage']:.1f}%, "
        f"PSNR {evaluation['psnr']:.1f} dB, {metrics['collision_steps']} collision steps; wrote {out}"
    )
