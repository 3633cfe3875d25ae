"""splatloop from Python: the Gymnasium environment against Gymnasium's own checker and the
dataset it writes, bad input, threads, and datasets as arrays."""

import json
import math
import os
import subprocess
import threading
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import splatloop

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ROOM = os.path.join(ROOT, "worlds", "room.xml")
# Small and quick: 160x120, 10 hidden views, a 20 s budget, the world waits for the mapper.
SMALL = dict(world=ROOM, width=160, height=120, latency="none", engine="cpu", test_views=10, budget=20)


def test_gymnasiums_checker_passes_and_make_gives_the_same_environment():
    env = splatloop.Env(**SMALL)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the checker's advice about unbounded Box spaces
        check_env(env, skip_render_check=True)
    env.close()
    made = gym.make("splatloop/Explore-v0", **SMALL)
    assert made.observation_space["rgb"].shape == (120, 160, 3)
    made.close()


def test_a_random_walk_returns_the_declared_arrays_and_the_dataset_holds_its_depth(tmp_path):
    out = tmp_path / "walk"
    env = splatloop.Env(out=str(out), **SMALL)
    obs, info = env.reset(seed=3)
    # The action space has its own generator: seeded, the walk (and its coverage) repeats.
    env.action_space.seed(0)
    seen = []
    total = 0.0
    for _ in range(20):
        for key, space in env.observation_space.spaces.items():
            assert obs[key].shape == space.shape, key
            assert obs[key].dtype == space.dtype, key
        assert env.observation_space.contains(obs)
        seen.append((info["time"], obs["depth"].copy(), obs["pose"].copy()))
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert not terminated
        total += reward
        if truncated:
            break
    assert truncated and math.isclose(info["time"], 20.0, abs_tol=0.01)
    # Rewards add up to the coverage gained, less the contact penalty.
    assert total <= info["coverage"] + 1e-9
    assert info["coverage"] > 0.05
    arrays = env.map
    n = len(arrays["means"])
    assert n == info["gaussians"] > 1000
    assert arrays["colours"].shape == (n, 3) and arrays["radii"].shape == (n,)
    assert np.all((arrays["opacities"] > 0) & (arrays["opacities"] < 1)) and np.all(arrays["radii"] > 0)
    env.save_ply(str(tmp_path / "map.ply"))
    metrics = env.write()
    assert metrics["ended"] == "budget" and metrics["frames"] == 100
    assert metrics["gaussians"] == n
    # The map saved mid-episode is the one written at its end (no step between them).
    assert (tmp_path / "map.ply").read_bytes() == (out / "map.ply").read_bytes()
    # The first frame is the dataset's first: depth within the PNGs' 0.2 mm quantisation.
    dataset = splatloop.Dataset(str(out))
    assert len(dataset) == 100
    for time, depth, pose in seen[:3]:
        frame = next(dataset[i] for i in range(len(dataset)) if abs(dataset[i]["timestamp"] - time) < 1e-6)
        assert np.max(np.abs(frame["depth"] - depth)) <= 0.5 / 5000 + 1e-6
        assert np.allclose(frame["pose"], pose, atol=1e-5)
    # Masks are on by default: uint16 ids that labels.json names, semantic = the instance's class.
    frame, labels = dataset[0], dataset.labels
    assert frame["instance"].dtype == np.uint16 and frame["instance"].shape == frame["depth"].shape
    class_of = {i["id"]: i["class"] for i in labels["instances"]}
    ids = np.unique(frame["instance"])
    assert len(ids) >= 3 and all(i == 0 or i in class_of for i in ids)
    expected = np.vectorize(lambda i: class_of.get(int(i), 0))(frame["instance"])
    assert np.array_equal(frame["semantic"], expected)
    assert "wall" in {c["name"] for c in labels["classes"]}
    env.close()


def test_bad_input_raises_the_named_exceptions():
    with pytest.raises(FileNotFoundError, match="nowhere.xml"):
        splatloop.Env(world="nowhere.xml")
    with pytest.raises(ValueError, match="possible values"):
        splatloop.Env(world=ROOM, latency="fast")
    with pytest.raises(ValueError, match="budget"):
        splatloop.Env(**{**SMALL, "budget": -1})
    env = splatloop.Env(**SMALL)
    env.reset(seed=1)
    with pytest.raises(ValueError, match="finite"):
        env.step([float("nan"), 0.0])
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        env.step([0.1, 0.2, 0.3])
    with pytest.warns(UserWarning, match="clipped"):
        env.step([5.0, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # said once
        env.step([5.0, 0.0])
    errors = []

    def elsewhere():
        try:
            env.step([0.0, 0.0])
        except RuntimeError as e:
            errors.append(str(e))

    thread = threading.Thread(target=elsewhere)
    thread.start()
    thread.join()
    assert errors and "thread" in errors[0]
    env.close()


def test_a_recorded_dataset_reads_back_as_arrays(tmp_path):
    binary = os.path.join(ROOT, "target", "debug", "splatloop")
    if not os.path.exists(binary):
        binary = os.path.join(ROOT, "target", "release", "splatloop")
    out = tmp_path / "rec"
    subprocess.run(
        [binary, "record", "--world", ROOM, "--duration", "2", "--width", "80", "--height", "60", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    dataset = splatloop.Dataset(str(out))
    lines = [l for l in (out / "groundtruth.txt").read_text().splitlines() if l and not l.startswith("#")]
    assert len(dataset) == len(lines) == 11  # 0 to 2 s at 5 frames per second
    frame = dataset[-1]
    assert frame["rgb"].shape == (60, 80, 3) and frame["rgb"].dtype == np.uint8
    assert frame["depth"].shape == (60, 80) and frame["depth"].dtype == np.float32
    camera = json.loads((out / "camera.json").read_text())
    assert np.allclose(frame["K"], np.array(camera["K"]))
    t, tx, ty, tz = (float(x) for x in lines[-1].split()[:4])
    assert frame["timestamp"] == pytest.approx(t)
    assert np.allclose(frame["pose"][:3, 3], [tx, ty, tz], atol=1e-6)
    with pytest.raises(IndexError):
        dataset[11]
    with pytest.raises(FileNotFoundError):
        splatloop.Dataset(str(tmp_path / "none"))
    # The same drive recorded from Python writes the same files.
    again = tmp_path / "again"
    summary = splatloop.record(str(again), world=ROOM, duration=2, width=80, height=60)
    assert summary["frames"] == 11 and summary["collision_steps"] == 0
    for name in ["groundtruth.txt", "camera.json", "depth/000005.png", "rgb/000005.png"]:
        assert (again / name).read_bytes() == (out / name).read_bytes(), name
    with pytest.raises(ValueError, match="duration"):
        splatloop.record(str(tmp_path / "bad"), world=ROOM, duration=-2)


def test_several_envs_in_one_process_and_in_async_subprocesses_agree():
    action = np.array([0.2, 0.1], np.float32)
    local = [splatloop.Env(**SMALL) for _ in range(2)]
    depths = []
    for env in local:
        env.reset(seed=2)
        for _ in range(3):
            obs, *_ = env.step(action)
        depths.append(obs["depth"])
    assert np.array_equal(depths[0], depths[1])
    for env in local:
        env.close()
    # Spawned, not forked: a child must not inherit this process's EGL contexts.
    envs = gym.make_vec(
        "splatloop/Explore-v0",
        num_envs=2,
        vectorization_mode="async",
        vector_kwargs={"context": "spawn"},
        **SMALL,
    )
    try:
        obs, _ = envs.reset(seed=[2, 2])
        for _ in range(3):
            obs, *_ = envs.step(np.stack([action, action]))
        assert obs["rgb"].shape == (2, 120, 160, 3)
        assert np.array_equal(obs["depth"][0], depths[0]) and np.array_equal(obs["depth"][1], depths[0])
    finally:
        envs.close()


class Arcs:
    """A planner in Python: a left arc, one second at a time; it counts frames and plans."""

    def __init__(self):
        self.frames = 0
        self.plans = []

    def observe(self, frame, map):
        assert frame["depth"].dtype == np.float32 and frame["pose"].shape == (4, 4)
        assert frame.rgb.shape == frame.depth.shape + (3,) and frame.rgb.dtype == np.uint8
        self.frames += 1

    def plan(self, observation, map):
        self.plans.append((observation["start"], len(map["means"])))
        return {"commands": [(0.2, 0.4)], "period": 1.0}


def test_a_python_planner_drives_the_loop_through_the_same_controller(tmp_path):
    planner = Arcs()
    metrics = splatloop.run(planner, out=str(tmp_path / "arcs"), **{**SMALL, "budget": 6})
    assert metrics["planner"] == "python-Arcs" and metrics["ended"] == "budget"
    assert metrics["planner_settings"]["class"] == "Arcs"
    assert planner.frames == 30 and len(planner.plans) == 6
    # Every plan starts where the last one's arc ended (latency none: the pose now), and the
    # map grows under it.
    (x0, y0, t0), n0 = planner.plans[0]
    (x5, y5, t5), n5 = planner.plans[5]
    assert n5 > n0 > 0
    turned = math.remainder(t5 - t0, math.tau)
    assert abs(turned - 5 * 0.4) < 0.1, turned
    chord = math.hypot(x5 - x0, y5 - y0)
    radius = 0.2 / 0.4
    assert abs(chord - 2 * radius * math.sin(turned / 2)) < 0.05, chord


def test_a_python_planners_bad_plan_ends_the_episode_and_is_raised(tmp_path):
    class TooFast:
        def plan(self, observation, map):
            return {"commands": [(3.0, 0.0)]}

    with pytest.raises(ValueError, match="outside the drive's limits"):
        splatloop.run(TooFast(), out=str(tmp_path / "fast"), **{**SMALL, "budget": 3})
    # Written all the same, saying why it ended.
    metrics = json.loads((tmp_path / "fast" / "metrics.json").read_text())
    assert metrics["ended"].startswith("the Python planner raised")

    class Done:
        def plan(self, observation, map):
            return "nothing to see"

    # Done: the robot idles while the mapper goes on to the budget (the same mapping time for
    # every planner), or the episode ends there with stop_when_done.
    metrics = splatloop.run(Done(), out=str(tmp_path / "done"), **{**SMALL, "budget": 3})
    assert metrics["ended"] == "budget (planner done at t = 0.0 s: nothing to see)"
    assert metrics["done_at"] == 0.0 and metrics["mapping_steps"] == 3
    metrics = splatloop.run(
        Done(), out=str(tmp_path / "stopped"), stop_when_done=True, **{**SMALL, "budget": 3}
    )
    assert metrics["ended"] == "nothing to see"
