"""``splatloop.run``: a whole episode with your own planner in splatloop's loop."""

from __future__ import annotations

import json
import os
from typing import Any

from ._splatloop import record_drive, run_with_planner
from .env import _words


def _command_words(out: str, options: dict[str, Any]) -> list[str]:
    """A command's flags with its output folder; ``overwrite=True`` is the bare switch."""
    overwrite = bool(options.pop("overwrite", False))
    return _words({**options, "out": os.fspath(out)}) + (["--overwrite"] if overwrite else [])


def run(planner: Any, out: str, **options: Any) -> dict:
    """Runs one episode as ``splatloop run`` does (its options as keyword arguments, the same
    defaults), with ``planner`` deciding every think period instead of a built-in one, and
    writes the episode folder to ``out`` (new or empty; ``overwrite=True`` replaces an earlier
    episode). Returns metrics.json's contents.

    ``planner.plan(observation, map)`` gets ``observation["start"]`` = (x, y, theta), the pose
    the plan begins from, and ``map``, a ``splatloop.Map`` (``means``, ``colours``,
    ``opacities``, ``radii``, ``uncertainty`` arrays, ``render``); it returns
    ``{"commands": [(v, w), ...], "period": 1.0}`` to drive (checked against the drive's
    limits), a ``Plan`` or ``PlanFailure`` of a built-in planner (``splatloop.planners.make``)
    to pass its decision on unchanged, a string to end the episode with that reason, or
    ``None`` for no plan (the host turns in place to look around, as for ours).
    ``planner.start(context)``, if defined, is called once before the first frame with the
    camera and the episode's seed (a ``PlannerContext``); ``planner.observe(frame, map)``, if
    defined, sees every frame (a ``Frame``: ``rgb``, ``depth``, ``pose``, ``K``, ``robot``).
    With ``latency="wall"`` the planner's own time is charged to simulated time, as ours is.
    An exception it raises ends the episode, which is still written, and is raised again here.
    """
    if "planner" in options:
        raise ValueError("give the planner object as planner=...; built-in ones run with splatloop.Env or the CLI")
    return json.loads(run_with_planner(_command_words(out, options), planner))


def record(out: str, **options: Any) -> dict:
    """Drives the robot open-loop and writes an RGB-D dataset with exact poses, as
    ``splatloop record`` does (its options as keyword arguments: ``world``, ``controls``,
    ``duration``, ``fps``, ``width``, ``height``, ...; ``overwrite=True`` replaces an earlier
    dataset). Returns the frame count, the collision steps and the final pose."""
    frames, collision_steps, final_pose = record_drive(_command_words(out, options))
    return {"frames": frames, "collision_steps": collision_steps, "final_pose": final_pose}
