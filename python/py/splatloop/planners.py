"""``splatloop.planners``: the built-in planners as Python objects, to wrap or compare with.

A planner in splatloop's loop is any object with ``plan(observation, map)``; optional
``start(context)`` (once, before the first frame) and ``observe(frame, map)`` (every frame).
``make("rtguide" | "fbe" | "agslam", **options)`` gives one of ours with exactly those methods,
so a Python planner can hold one and pass its calls on::

    class Cautious:
        def __init__(self):
            self.inner = splatloop.planners.make("rtguide")
        def start(self, context):
            self.inner.start(context)
        def observe(self, frame, map):
            self.inner.observe(frame, map)
        def plan(self, observation, map):
            plan = self.inner.plan(observation, map)   # a Plan, a PlanFailure or a string
            return plan

A ``Plan`` (``commands``, ``period``, ``states``, ``target``, ``score``, ``commit``) or
``PlanFailure`` (``kind``, ``message``, ``recovery``) returned unchanged is driven exactly as
the built-in planner's own episode drives it.
"""

from __future__ import annotations

from typing import Any

from ._splatloop import BuiltinPlanner, Plan, PlanFailure, PlannerContext
from .env import _words

__all__ = ["BuiltinPlanner", "Plan", "PlanFailure", "PlannerContext", "make", "NAMES"]

#: The built-in planners ``make`` builds (the survey knows the world: only an episode has it).
NAMES = ("rtguide", "fbe", "agslam")


def make(name: str, **options: Any) -> BuiltinPlanner:
    """The built-in planner ``name`` with ``splatloop run``'s planner options as keyword
    arguments (``rtguide_commit=2.0``, ``pose_weight=0.0``, ...; the same defaults). It is
    built at ``start(context)``, when the episode's camera is known."""
    return BuiltinPlanner(name, _words(options))
