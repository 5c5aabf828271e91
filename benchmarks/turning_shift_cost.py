"""The cost of a geometry parameter's shift on a part that turns (issue 34; docs/performance.md, "The turning shift's
cost (issue 34)").

The gimbal's ring offset through its inner ring's latch (tests/test_geometry_sensitivities_turning_events.py
RING_LATCH: 41 steps) without sensitivities, by k1 alone (the loop of steps) and by X and k1 (X shifts the rings on the
outer hinge, a part that turns: every forward step from Python), forward and with ``sensitivity_method: adjoint``: each
run in process after one warm run of each, ``--rounds`` rounds alternating, medians of wall and CPU
(``time.process_time``) and each one's ratio to the run without. ``--pieces``: the wall time per run of the pieces of
the sensitivities by X and k1 (each call timed where it is not inside itself). ``--smooth``: the ring offset without
the latch (tests/test_geometry_sensitivities_link_length.py RING: 30 steps, no event); ``--forward``: the forward
cases alone; ``--raw``: each round's (wall, CPU) in seconds too, for medians across invocations. Run it under
``chrt -f 10`` where the machine is loaded.

    python benchmarks/turning_shift_cost.py [--rounds 5] [--pieces] [--smooth] [--forward] [--raw]
"""
from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
import yaml  # noqa: E402

import latdyn  # noqa: E402
from tests.test_geometry_sensitivities_link_length import RING  # noqa: E402
from tests.test_geometry_sensitivities_turning_events import RING_LATCH  # noqa: E402

#: the scene timed: RING_LATCH, or RING with --smooth
SCENE = [RING_LATCH]

#: (name, its parameters (None: no sensitivities), adjoint)
CASES = [("without", None, False), ("k1", ["k1"], False), ("X, k1", ["X", "k1"], False),
         ("without", None, True), ("k1", ["k1"], True), ("X, k1", ["X", "k1"], True)]
#: (module, class, method) timed by --pieces
PIECES = [("latdyn.analyses.transient_sensitivities", "TransientSensitivities", "step"),
          ("latdyn.analyses.transient_sensitivities", "TransientSensitivities", "_step_system"),
          ("latdyn.analyses.transient_sensitivities", "TransientSensitivities", "_jump"),
          ("latdyn.analyses.transient_sensitivities", "TransientSensitivities", "record"),
          ("latdyn.analyses.adjoint_sensitivities", "AdjointSensitivities", "reverse"),
          ("latdyn.analyses.transient_sensitivities", "TransientSensitivities", "residual_derivatives"),
          ("latdyn.analyses.geometry_sensitivities", "ReferenceGeometry", "add"),
          ("latdyn.analyses.geometry_sensitivities", "ReferenceGeometry", "_add_shifts"),
          ("latdyn.analyses.geometry_sensitivities", "ReferenceGeometry", "reference_forces"),
          ("latdyn.analyses.geometry_sensitivities", "ReferenceGeometry", "at_state"),
          ("latdyn.analyses.geometry_sensitivities", "ReferenceGeometry", "_add_link_inertia"),
          ("latdyn.analyses.geometry_sensitivities", "ReferenceGeometry", "shifts")]


def scene(parameters, adjoint: bool):
    data = yaml.safe_load(SCENE[0])
    if parameters is None:
        del data["solve"]["sensitivities"]
    else:
        data["solve"]["sensitivities"] = parameters
        if adjoint:
            data["solve"]["sensitivity_method"] = "adjoint"
    return latdyn.load_scene(data)


def timed(parameters, adjoint: bool) -> tuple[float, float]:
    loaded = scene(parameters, adjoint)
    wall, cpu = time.perf_counter(), time.process_time()
    latdyn.run(loaded)
    return time.perf_counter() - wall, time.process_time() - cpu


def costs(rounds: int, forward: bool, raw: bool) -> None:
    cases = [i for i, (_, _, adjoint) in enumerate(CASES) if not (forward and adjoint)]
    for i in cases:
        timed(*CASES[i][1:])
    taken = {i: [] for i in cases}
    for _ in range(rounds):
        for i in cases:
            taken[i].append(timed(*CASES[i][1:]))
    for i in cases:
        name, _, adjoint = CASES[i]
        if raw:
            print(f"raw {'adjoint' if adjoint else 'forward'} {name}: {taken[i]}")
        without = np.median(taken[3 if adjoint else 0], axis=0)
        wall, cpu = np.median(taken[i], axis=0)
        print(f"{'adjoint' if adjoint else 'forward'} {name:8s} wall {1e3 * wall:7.1f} ms ({wall / without[0]:.2f} ×)  "
              f"CPU {1e3 * cpu:7.1f} ms ({cpu / without[1]:.2f} ×)")


def pieces(rounds: int) -> None:
    import importlib

    spent: dict[str, list] = {}
    for module, owner, method in PIECES:
        cls = getattr(importlib.import_module(module), owner)
        original, key = getattr(cls, method), f"{owner}.{method}"
        spent[key] = [0.0, 0, False]

        def wrapped(*args, _original=original, _key=key, **kwargs):
            entry = spent[_key]
            if entry[2]:
                return _original(*args, **kwargs)
            entry[2], start = True, time.perf_counter()
            try:
                return _original(*args, **kwargs)
            finally:
                entry[0] += time.perf_counter() - start
                entry[1] += 1
                entry[2] = False
        setattr(cls, method, functools.wraps(original)(wrapped))
    for adjoint in (False, True):
        timed(["X", "k1"], adjoint)
        for entry in spent.values():
            entry[0], entry[1] = 0.0, 0
        total = sum(timed(["X", "k1"], adjoint)[0] for _ in range(rounds))
        print(f"{'adjoint' if adjoint else 'forward'} by X, k1: {1e3 * total / rounds:.1f} ms a run")
        for key, (seconds, calls, _) in sorted(spent.items(), key=lambda item: -item[1][0]):
            if calls:
                print(f"  {key:45s} {1e3 * seconds / rounds:7.2f} ms  {calls // rounds:4d} calls")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--pieces", action="store_true")
    parser.add_argument("--smooth", action="store_true")
    parser.add_argument("--forward", action="store_true")
    parser.add_argument("--raw", action="store_true")
    arguments = parser.parse_args()
    if arguments.smooth:
        SCENE[0] = RING
    if arguments.pieces:
        pieces(arguments.rounds)
    else:
        costs(arguments.rounds, arguments.forward, arguments.raw)
    print(f"1-minute load {os.getloadavg()[0]:.1f}")
