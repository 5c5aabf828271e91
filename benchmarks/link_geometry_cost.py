"""Geometry moving a link's own geometry (issue 34; docs/performance.md, "Geometry moving a link's own geometry (issue
34)").

The cost of the sensitivities by a parameter that moves a rigid link's start point or a guide's origin on a body that
never turns (the scenes of tests/test_geometry_sensitivities_link_geometry.py: the gimbal's first hinge point on its
fixed base and on a prescribed base, a cart's guide origin on the ground and on a fixed rail, the pendulum's hinge
point on the sliding cart, a carriage's guide origin on the cart) and, to compare, by a parameter that is not geometry
(k1, k): each scene's run in process without sensitivities, by its first parameter alone and by both, five rounds
alternating after one warm run, medians of CPU (``time.process_time``) and wall. Run it under ``chrt -f 10`` where the
machine is loaded.

    python benchmarks/link_geometry_cost.py
"""
from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import latdyn  # noqa: E402
from tests.test_geometry_sensitivities_link_geometry import (CART, CART_HINGE, GIMBAL_HINGE_CARRIED,  # noqa: E402
                                                             GIMBAL_HINGE_POINT, RAIL, TABLE)

#: name -> (scene, its parameters in the order measured: the first alone, then both)
SCENES = {
    "gimbal, k1 first": (GIMBAL_HINGE_POINT, ["k1", "X"]),
    "gimbal's hinge point on its fixed base": (GIMBAL_HINGE_POINT, ["X", "k1"]),
    "the same on a prescribed base": (GIMBAL_HINGE_CARRIED, ["X", "k1"]),
    "cart, k first": (CART, ["k", "X"]),
    "cart's guide origin on the ground": (CART, ["X", "k"]),
    "the same on a fixed rail": (RAIL, ["X", "k"]),
    "the pendulum's hinge point on the sliding cart": (CART_HINGE, ["X", "k"]),
    "a carriage's guide origin on the cart": (TABLE, ["X", "k"]),
}


def _once(data) -> tuple[float, float]:
    cpu, wall = time.process_time(), time.perf_counter()
    latdyn.run(latdyn.load_scene(data))
    return time.process_time() - cpu, time.perf_counter() - wall


def main() -> None:
    for name, (text, parameters) in SCENES.items():
        runs = {}
        for label, names in (("without", None), ("first", parameters[:1]), ("both", parameters)):
            data = yaml.safe_load(text)
            data["solve"].pop("sensitivities", None)
            if names is not None:
                data["solve"]["sensitivities"] = names
            runs[label] = data
        for data in runs.values():
            _once(data)   # the kernels, laws and caches warm
        times = {label: [] for label in runs}
        for _ in range(5):
            for label, data in runs.items():
                times[label].append(_once(data))
        cpu = {label: statistics.median(c for c, _ in v) for label, v in times.items()}
        wall = {label: statistics.median(w for _, w in v) for label, v in times.items()}
        print(f"{name}: without {cpu['without'] * 1e3:.1f} ms CPU / {wall['without'] * 1e3:.1f} ms wall; "
              f"by {parameters[0]} {cpu['first'] * 1e3:.1f} / {wall['first'] * 1e3:.1f} "
              f"({cpu['first'] / cpu['without']:.2f} x CPU, {wall['first'] / wall['without']:.2f} x wall); by both "
              f"{cpu['both'] * 1e3:.1f} / {wall['both'] * 1e3:.1f} ({cpu['both'] / cpu['without']:.2f} x, "
              f"{wall['both'] / wall['without']:.2f} x)", flush=True)


if __name__ == "__main__":
    main()
