"""``python -m splatloop run ... --planner python:MODULE:CLASS``: what the binary's
``splatloop run --planner python:...`` starts. The class is imported (MODULE a dotted module
importable from the working folder, or a ``.py`` file), made with no arguments, and runs the
episode with the binary's progress bar, signals, summary and exit code."""

from __future__ import annotations

import importlib
import importlib.util
import os
import sys
from typing import Any, Sequence

from ._splatloop import run_cli

USAGE = "usage: python -m splatloop run --planner python:MODULE:CLASS [splatloop run's options]"


def planner_spec(words: Sequence[str]) -> str:
    """The ``--planner`` value among ``splatloop run``'s words."""
    for i, word in enumerate(words):
        if word == "--planner" and i + 1 < len(words):
            return words[i + 1]
        if word.startswith("--planner="):
            return word.split("=", 1)[1]
    raise ValueError("no --planner python:MODULE:CLASS given")


def load_planner(spec: str) -> Any:
    """Imports and makes the planner ``python:MODULE:CLASS`` names."""
    if not spec.startswith("python:") or spec.count(":") < 2:
        raise ValueError(f"{spec!r}: a Python planner is python:MODULE:CLASS")
    module_name, class_name = spec[len("python:") :].rsplit(":", 1)
    if module_name.endswith(".py"):
        path = os.path.abspath(module_name)
        if not os.path.isfile(path):
            raise FileNotFoundError(f"{path}: no such Python file (from --planner {spec})")
        name = "splatloop_planner_" + os.path.splitext(os.path.basename(path))[0]
        loader = importlib.util.spec_from_file_location(name, path)
        if loader is None or loader.loader is None:
            raise ImportError(f"cannot import {path}")
        module = importlib.util.module_from_spec(loader)
        sys.modules[name] = module
        loader.loader.exec_module(module)
    else:
        if "" not in sys.path and os.getcwd() not in sys.path:
            sys.path.insert(0, os.getcwd())
        module = importlib.import_module(module_name)
    try:
        cls = getattr(module, class_name)
    except AttributeError:
        raise ImportError(f"{module_name} has no class {class_name} (from --planner {spec})") from None
    planner = cls()
    if not callable(getattr(planner, "plan", None)):
        raise TypeError(f"{class_name} has no plan(observation, map) method")
    return planner


def main(argv: Sequence[str]) -> int:
    """Runs ``run WORDS`` with the Python planner the words name; the exit code."""
    if not argv or argv[0] != "run":
        print(USAGE, file=sys.stderr)
        return 2
    words = list(argv[1:])
    try:
        planner = load_planner(planner_spec(words))
    except (ImportError, ValueError, TypeError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return run_cli(words, planner)
