"""splatloop from Python: the closed loop as a Gymnasium environment, datasets as arrays.

    import splatloop
    env = splatloop.Env(world="worlds/room.xml", latency="none", budget=60)
    obs, info = env.reset(seed=3)
    obs, reward, terminated, truncated, info = env.step([0.2, 0.3])

``Env`` takes ``splatloop run``'s options as keyword arguments (the same names with ``_``
for ``-``, the same defaults); ``Dataset`` reads an episode or ``record`` folder frame by
frame. ``gymnasium.make("splatloop/Explore-v0", ...)`` gives the same environment.
"""

from . import planners
from ._splatloop import Dataset, Episode, Frame, Map, Plan, PlanFailure, PlannerContext, __version__
from .env import COLLISION_PENALTY, Env
from .loop import record, run

__all__ = [
    "COLLISION_PENALTY",
    "Dataset",
    "Env",
    "Episode",
    "Frame",
    "Map",
    "Plan",
    "PlanFailure",
    "PlannerContext",
    "planners",
    "record",
    "run",
    "__version__",
]

try:
    import gymnasium as _gymnasium

    if "splatloop/Explore-v0" not in _gymnasium.registry:
        _gymnasium.register(id="splatloop/Explore-v0", entry_point="splatloop.env:Env")
except ImportError:  # gymnasium is a dependency; a bare install still reads datasets
    pass
