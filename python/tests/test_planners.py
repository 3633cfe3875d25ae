"""Planners across the language line: a Python planner that passes a built-in planner's
decisions on gives the binary's episode bit for bit; env.plan; the map rendered from Python
against `splatloop render`; `--planner python:MODULE:CLASS` from the CLI and in a sweep."""

import csv
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import splatloop

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ROOM = os.path.join(ROOT, "worlds", "room.xml")
SMALL = dict(world=ROOM, width=160, height=120, latency="none", engine="cpu", test_views=10)
# The same options as `splatloop run` words.
SMALL_WORDS = ["--world", ROOM, "--width", "160", "--height", "120", "--latency", "none", "--engine", "cpu", "--test-views", "10"]
# Rows of trajectory.png above this hold the title, which names the planner.
TITLE_BAND = 24


def binary():
    for profile in ("debug", "release"):
        path = os.path.join(ROOT, "target", profile, "splatloop")
        if os.path.exists(path):
            return path
    raise FileNotFoundError("build splatloop first (cargo build)")


def splatloop_cli(*words, check=True, **kwargs):
    env = {**os.environ, "SPLATLOOP_PYTHON": sys.executable}
    return subprocess.run([binary(), *words], check=check, capture_output=True, text=True, env=env, **kwargs)


class PassOn:
    """A Python planner that holds a built-in one and returns its decisions unchanged."""

    def __init__(self, name):
        self.inner = splatloop.planners.make(name)
        self.plans = 0

    def start(self, context):
        assert context.K[0][0] > 0 and context.width == 160
        self.inner.start(context)

    def observe(self, frame, map):
        self.inner.observe(frame, map)

    def plan(self, observation, map):
        self.plans += 1
        return self.inner.plan(observation, map)


@pytest.mark.parametrize("name", ["rtguide", "fbe"])
def test_a_python_planner_passing_on_a_builtins_plans_gives_the_binarys_episode(tmp_path, name):
    ours = tmp_path / "binary"
    splatloop_cli("run", *SMALL_WORDS, "--planner", name, "--seed", "3", "--budget", "25", "--out", str(ours))
    planner = PassOn(name)
    theirs = tmp_path / "python"
    metrics = splatloop.run(planner, out=str(theirs), seed=3, budget=25, **SMALL)
    expected = json.loads((ours / "metrics.json").read_text())
    assert planner.plans >= 5
    assert metrics["planner"] == "python-PassOn"
    for key in ["gaussians", "ended", "frames", "mapping_steps", "collision_steps", "recovery_events", "plan_failures", "path_length", "evaluation", "coverage_over_time"]:
        assert metrics[key] == expected[key], key
    for name_ in ["groundtruth.txt", "map.ply", "points.ply"]:
        assert (theirs / name_).read_bytes() == (ours / name_).read_bytes(), name_
    # The figure: the same pixels under the title (which names the planner).
    a = np.asarray(Image.open(ours / "trajectory.png"))
    b = np.asarray(Image.open(theirs / "trajectory.png"))
    assert a.shape == b.shape and np.array_equal(a[TITLE_BAND:], b[TITLE_BAND:])


def unicycle(state, command, period):
    """The unicycle model's state after `command` held for `period` seconds."""
    x, y, theta = state
    v, w = command
    if abs(w) < 1e-9:
        return x + v * period * math.cos(theta), y + v * period * math.sin(theta), theta
    t = theta + w * period
    return x + v / w * (math.sin(t) - math.sin(theta)), y - v / w * (math.cos(t) - math.cos(theta)), t


def test_env_plan_says_what_a_builtin_would_do_and_its_first_command_drives_there():
    env = splatloop.Env(**SMALL, budget=20, advisors=["fbe", "rtguide"])
    obs, info = env.reset(seed=3)
    for _ in range(4):
        obs, reward, terminated, truncated, info = env.step(None)
    for name in ["fbe", "rtguide"]:
        plan = env.plan(name)
        if name == "rtguide":
            assert isinstance(plan, splatloop.Plan)
        if not isinstance(plan, splatloop.Plan):
            continue
        assert len(plan.states) == len(plan.commands) + 1
        assert np.allclose(plan.states[0], info["robot"], atol=1e-9)
        for k, command in enumerate(plan.commands):
            assert np.allclose(plan.states[k + 1], unicycle(plan.states[k], command, plan.period), atol=1e-6)
    before = env.map
    first = plan.states[1]
    obs, reward, terminated, truncated, info = env.step(plan.commands[0])
    # The drive follows the model to within a couple of centimetres in a second.
    assert math.hypot(info["robot"][0] - first[0], info["robot"][1] - first[1]) < 0.03
    # A map is a snapshot: the one read before the step kept its Gaussians.
    assert len(before) < len(env.map)
    with pytest.warns(UserWarning, match="history"):
        env.plan("agslam")
    with pytest.raises(ValueError, match="unknown planner"):
        env.plan("frontier2")
    env.close()


def test_the_map_rendered_from_python_is_what_splatloop_render_writes(tmp_path):
    out = tmp_path / "episode"
    env = splatloop.Env(out=str(out), **SMALL, budget=8)
    env.reset(seed=2)
    for _ in range(8):
        obs, *_ = env.step(None)
    the_map = env.map
    metrics = env.write()
    assert metrics["gaussians"] == len(the_map)
    rendered = tmp_path / "rendered"
    splatloop_cli(
        "render", "--map", str(out / "map.ply"), "--poses", str(out / "groundtruth.txt"),
        "--camera", str(out / "camera.json"), "--engine", "cpu", "--out", str(rendered),
    )
    dataset = splatloop.Dataset(str(rendered))
    for index in [0, len(dataset) // 2, len(dataset) - 1]:
        frame = dataset[index]
        rgb, depth = the_map.render(frame["pose"], frame["K"], 160, 120)
        assert rgb.shape == (120, 160, 3) and depth.shape == (120, 160)
        # The PNGs hold 8-bit colour exactly and depth to 0.2 mm; the pose went through a TUM
        # file's digits.
        assert np.mean(np.abs(rgb.astype(int) - frame["rgb"].astype(int)) <= 1) > 0.99
        both = (depth > 0) & (frame["depth"] > 0)
        assert both.mean() > 0.2
        assert np.median(np.abs(depth[both] - frame["depth"][both])) < 1e-3
        assert np.mean((depth > 0) != (frame["depth"] > 0)) < 0.01
    with pytest.raises(ValueError, match="rotation"):
        the_map.render(np.eye(4) * 2, frame["K"], 160, 120)
    with pytest.raises(ValueError, match=r"\(4, 4\)"):
        the_map.render(np.eye(3), frame["K"], 160, 120)


ARCS = '''
class Arcs:
    """A left arc, one second at a time."""

    def plan(self, observation, map):
        return {"commands": [(0.2, 0.4)], "period": 1.0}
'''


def test_the_cli_runs_a_python_planner_and_a_sweep_tables_it_beside_ours(tmp_path):
    module = tmp_path / "arcs.py"
    module.write_text(ARCS)
    spec = f"python:{module}:Arcs"
    episode = tmp_path / "one"
    done = splatloop_cli("run", *SMALL_WORDS, "--planner", spec, "--budget", "4", "--out", str(episode))
    assert "explored 4 sim s" in done.stdout, done.stdout + done.stderr
    metrics = json.loads((episode / "metrics.json").read_text())
    assert metrics["planner"] == "python-Arcs" and metrics["ended"] == "budget"
    # Clear errors: a missing class, a malformed name.
    missing = splatloop_cli("run", *SMALL_WORDS, "--planner", f"python:{module}:Nope", "--out", str(tmp_path / "x"), check=False)
    assert missing.returncode == 2 and "has no class Nope" in missing.stderr
    malformed = splatloop_cli("run", "--planner", "python:nomodule", check=False)
    assert malformed.returncode == 2 and "python:MODULE:CLASS" in malformed.stderr
    # A sweep: our planner and the Python one in the same table.
    sweep = tmp_path / "sweep"
    splatloop_cli(
        "sweep", "--worlds", ROOM, "--planners", f"fbe,{spec}", "--seeds", "1", "--budget", "4",
        "--width", "160", "--height", "120", "--latency", "none", "--engine", "cpu", "--test-views", "10",
        "--out", str(sweep), "--jobs", "2",
    )
    rows = list(csv.DictReader(open(sweep / "results.csv")))
    assert sorted(r["planner"] for r in rows) == ["fbe", "python-Arcs"]
    assert all(r["status"] == "complete" for r in rows), rows
    assert (sweep / "room" / "python-Arcs" / "1" / "metrics.json").exists()
    assert "python-Arcs" in (sweep / "summary.md").read_text()
