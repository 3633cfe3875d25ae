"""``splatloop.Env``: one closed-loop episode per reset, driven by ``[v, w]`` actions.

Each ``step`` holds the action for one think period (1 simulated second): the robot drives it
while the camera takes its frames and the mapper maps the frame the step began with. The
observation is the newest frame: ``rgb`` (H, W, 3) uint8, ``depth`` (H, W) float32 metres
(0 where nothing returned), ``pose`` (4, 4) float64 world_from_camera in the OpenCV optical
frame, ``K`` (3, 3) float64.

Reward: the coverage the step added on the episode's hidden surface points (metrics.json's
coverage, a fraction in [0, 1]), minus ``COLLISION_PENALTY`` times the fraction of the step's
physics steps with the robot touching something. ``terminated``: the robot is stuck by the
host's rule (the same one that ends ``splatloop run``); ``truncated``: the budget is spent.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import threading
import warnings
from typing import Any, Optional, Sequence

import gymnasium as gym
import numpy as np

from ._splatloop import Episode, Map

#: Reward lost per think period spent wholly in contact (a period half in contact loses half).
COLLISION_PENALTY = 0.01


def _words(options: dict[str, Any]) -> list[str]:
    """``splatloop run``'s flags from keyword arguments: ``rtguide_tour=False`` is
    ``--rtguide-tour=false`` (one word each, so negative numbers stay values)."""
    words: list[str] = []
    for key, value in options.items():
        if value is None:
            continue
        if isinstance(value, bool):
            value = "true" if value else "false"
        words.append("--" + key.replace("_", "-") + "=" + str(value))
    return words


class Env(gym.Env):
    """The closed loop as a Gymnasium environment; keyword arguments are ``splatloop run``'s
    options (``world``, ``budget``, ``latency``, ``width``, ``height``, ``engine``,
    ``planner`` and the planners' options, ...), with its defaults. ``out``: the folder
    ``write`` (or ``close``) leaves the last episode in; without it, episodes go to a
    temporary folder that ``close`` removes."""

    metadata = {"render_modes": ["rgb_array"]}

    def __init__(
        self,
        out: Optional[str] = None,
        render_mode: Optional[str] = None,
        advisors: Sequence[str] = (),
        **options: Any,
    ):
        if "overwrite" in options:
            raise ValueError("overwrite is the environment's: each reset starts a new episode folder")
        self._advisors = [str(name) for name in advisors]
        self._options = dict(options)
        self._seed = int(self._options.pop("seed", 1))
        self._out = os.fspath(out) if out is not None else None
        self._scratch = tempfile.mkdtemp(prefix="splatloop-env-")
        self._resets = 0
        self._episode: Optional[Episode] = None
        self._thread = threading.get_ident()
        self._warned_clip = False
        self.render_mode = render_mode
        # A first episode answers the camera size and the drive's limits (and checks the options
        # now, where the user wrote them).
        probe = self._open(self._seed)
        frame = probe.observe()
        height, width = frame["depth"].shape
        self._limits = probe.limits()
        self._episode = probe
        self._last_obs = self._obs(frame)
        max_forward, max_turn = self._limits
        self.action_space = gym.spaces.Box(
            low=np.array([0.0, -max_turn], dtype=np.float32),
            high=np.array([max_forward, max_turn], dtype=np.float32),
            dtype=np.float32,
        )
        self.observation_space = gym.spaces.Dict(
            {
                "rgb": gym.spaces.Box(0, 255, (height, width, 3), np.uint8),
                "depth": gym.spaces.Box(0.0, np.inf, (height, width), np.float32),
                "pose": gym.spaces.Box(-np.inf, np.inf, (4, 4), np.float64),
                "K": gym.spaces.Box(-np.inf, np.inf, (3, 3), np.float64),
            }
        )

    def _folder(self) -> str:
        return os.path.join(self._scratch, f"episode-{self._resets}")

    def _open(self, seed: int) -> Episode:
        self._resets += 1
        words = _words({**self._options, "seed": seed, "out": self._folder()})
        episode = Episode(words + ["--overwrite"])
        for name in self._advisors:
            episode.advise(name)
        self._stepped = False
        return episode

    def _check_thread(self) -> None:
        if threading.get_ident() != self._thread:
            raise RuntimeError(
                "a splatloop Env holds an EGL context and is used only from the thread that made it; "
                "make one Env per thread (or per process, as gymnasium.vector.AsyncVectorEnv does)"
            )

    @staticmethod
    def _obs(frame: dict) -> dict:
        return {key: frame[key] for key in ("rgb", "depth", "pose", "K")}

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        """A new episode (seeded: the sensor noise, the hidden test set and a random spawn);
        returns the first frame and the info."""
        self._check_thread()
        super().reset(seed=seed)
        if options:
            unknown = set(options) - {"spawn"}
            if unknown:
                raise ValueError(f"reset options {sorted(unknown)}: only 'spawn' may change per episode")
            self._options.update(options)
        # The episode the constructor opened (to learn the camera) serves the first reset when
        # nothing about it changed: opening one samples the hidden test set, which takes a while.
        unchanged = not options and (seed is None or int(seed) == self._seed)
        if seed is not None:
            self._seed = int(seed)
        if not (unchanged and self._episode is not None and not self._stepped and self._resets == 1):
            self._drop()
            self._episode = self._open(self._seed)
        frame = self._episode.observe()
        self._coverage = self._episode.coverage() or 0.0
        self._last_obs = self._obs(frame)
        info = {"time": frame["time"], "robot": self._episode.pose(), "gaussians": 0, "coverage": self._coverage}
        return self._last_obs, info

    def _action(self, action) -> tuple[float, float]:
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (2,):
            raise ValueError(f"an action is [v, w] (m/s, rad/s), shape (2,); got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"an action must be finite; got {a.tolist()}")
        # The drive's own limits (the float32 Box rounds 0.6 up to 0.60000002).
        max_forward, max_turn = self._limits
        low, high = np.array([0.0, -max_turn]), np.array([max_forward, max_turn])
        clipped = np.clip(a, low, high)
        beyond = np.any(np.abs(clipped - a) > 1e-6 * np.maximum(1.0, np.abs(high)))
        if beyond and not self._warned_clip:
            warnings.warn(
                f"action {a.tolist()} clipped to the drive's limits (0 <= v <= {high[0]} m/s, "
                f"|w| <= {high[1]} rad/s); said once",
                stacklevel=3,
            )
            self._warned_clip = True
        return float(clipped[0]), float(clipped[1])

    def step(self, action):
        """Drives ``action`` = [v, w] for one think period; ``None`` lets the episode's own
        planner (``planner=...``, RT-GuIDE by default) decide, as in ``splatloop run``."""
        self._check_thread()
        if self._episode is None:
            raise RuntimeError("call reset() before step()")
        if action is not None:
            v, w = self._action(action)
            self._episode.apply(v, w)
        report = self._episode.step()
        self._stepped = True
        ended = report["ended"]
        frame = self._episode.observe() if ended is None else None
        if frame is not None:
            self._last_obs = self._obs(frame)
        coverage = self._episode.coverage()
        gained = 0.0 if coverage is None else coverage - self._coverage
        self._coverage = coverage or 0.0
        contact = report["collision_steps"] / self._episode.steps_per_period()
        reward = gained - COLLISION_PENALTY * contact
        terminated = ended is not None and ended.startswith("stuck")
        truncated = ended == "budget"
        if ended is not None and not (terminated or truncated):
            raise RuntimeError(f"the episode ended: {ended}")
        info = {
            "time": report["time"],
            "robot": report["pose"],
            "collision_steps": report["collision_steps"],
            "gaussians": report["gaussians"],
            "coverage": self._coverage,
            "ended": ended,
        }
        return self._last_obs, float(reward), terminated, truncated, info

    @property
    def map(self) -> Map:
        """The current episode's map (a snapshot): ``means`` (N, 3), ``colours`` (N, 3),
        ``opacities`` (N,), ``radii`` (N,) metres, ``uncertainty`` (N,) as arrays, ``len(map)``
        Gaussians, ``render(world_from_camera, K, width, height) -> (rgb, depth)`` with the
        episode's engine, ``save_ply(path)``."""
        self._check_thread()
        if self._episode is None:
            raise RuntimeError("no episode: call reset() first")
        return self._episode.map()

    def plan(self, name: str):
        """What the built-in planner ``name`` (rtguide, fbe, agslam, survey) would do from the
        robot's pose now: a ``Plan`` (``commands``, ``period``, ``states`` (x, y, theta) the
        unicycle model predicts, ``target``, ``score``), a ``PlanFailure`` or a string (it has
        nothing left to do). Nothing moves: ``env.step(plan.commands[0])`` drives its first
        command. Planners keep a history of the frames they saw: name them in
        ``Env(advisors=[...])`` to have the whole episode's; one first asked later starts its
        history then (said once as a warning)."""
        self._check_thread()
        if self._episode is None:
            raise RuntimeError("no episode: call reset() first")
        if name not in ("rtguide", "fbe", "agslam", "survey"):
            raise ValueError(f"unknown planner {name!r}; env.plan asks rtguide, fbe, agslam or survey")
        if name not in self._advisors:
            if self._stepped:
                warnings.warn(
                    f"env.plan({name!r}): {name} sees frames from now on, not the episode's earlier "
                    f"ones; give advisors=[{name!r}] to Env for its whole history",
                    stacklevel=2,
                )
            self._advisors.append(name)
            self._episode.advise(name)
        return self._episode.consult(name)

    def save_ply(self, path: str) -> None:
        """Writes the current map as a 3DGS PLY (with RT-GuIDE's ``uncertainty``)."""
        self._check_thread()
        if self._episode is None:
            raise RuntimeError("no episode: call reset() first")
        self._episode.save_ply(os.fspath(path))

    def render(self):
        """The newest camera image (``render_mode="rgb_array"``)."""
        return self._last_obs["rgb"] if self.render_mode == "rgb_array" else None

    def write(self, out: Optional[str] = None) -> dict:
        """Evaluates the current episode and writes its folder as ``splatloop run`` does (map.ply,
        metrics.json, the dataset); moved to ``out`` (or the Env's ``out``) when given. Returns
        metrics.json's contents. The episode cannot be stepped after."""
        import json

        self._check_thread()
        if self._episode is None:
            raise RuntimeError("no episode to write: call reset() first")
        metrics = json.loads(self._episode.finish())
        self._episode = None
        target = out if out is not None else self._out
        if target is not None:
            target = os.fspath(target)
            if os.path.exists(target) and os.listdir(target):
                raise FileExistsError(f"{target} is not empty; give a new folder")
            if os.path.exists(target):
                os.rmdir(target)
            shutil.move(self._folder(), target)
        return metrics

    def _drop(self) -> None:
        self._episode = None

    def close(self):
        """Writes the last episode to ``out`` when one was given, then removes the scratch
        folder."""
        if self._episode is not None and self._out is not None and threading.get_ident() == self._thread:
            self.write()
        self._episode = None
        shutil.rmtree(self._scratch, ignore_errors=True)
