"""Geometry parameters with rigid links and guides (issue 34; docs/performance.md, "Geometry parameters with rigid
links and guides (issue 34)").

The cost of the sensitivities by a geometry parameter on the scenes of tests/test_geometry_sensitivities_links.py (the
placed gimbal of rigid links, the mass on a guide at a placed arm's tip, a PD reading the placed knee's displacement, the
placed gimbal's PD of a spring torque, a latch on the placed gimbal, the gimbal on a prescribed base, controllers with
states and sampled) and, to compare, the same scenes by a parameter that
is not geometry (k1, k) and the arm placed without links (tests/test_sensitivities_refusals_lifted.py PLACED_PD): each
scene's run in process without sensitivities, by its first parameter alone and by both, five rounds alternating after
one warm run, medians of CPU (``time.process_time``) and wall. Run it under ``chrt -f 10`` where the machine is loaded.

    python benchmarks/geometry_links_cost.py
"""
from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import latdyn  # noqa: E402
from tests.test_geometry_sensitivities_links import (GIMBAL_CARRIED, GIMBAL_INTEGRAL, GIMBAL_PLACED,  # noqa: E402
                                                     GIMBAL_TORQUE, GUIDE_PLACED, LATCH_PLACED, PD_KNEE, PI_ARM,
                                                     SAMPLED_ARM)
from tests.test_sensitivities_refusals_lifted import PLACED_PD  # noqa: E402

#: name -> (scene, its parameters in the order measured: the first alone, then both)
SCENES = {
    "guide, k first": (GUIDE_PLACED, ["k", "L"]),
    "gimbal, k1 first": (GIMBAL_PLACED, ["k1", "X"]),
    "arm placed, no links": (PLACED_PD, ["X", "Kp"]),
    "gimbal placed": (GIMBAL_PLACED, ["X", "k1"]),
    "guide placed": (GUIDE_PLACED, ["L", "k"]),
    "PD of the knee's displacement": (PD_KNEE, ["X", "Kp"]),
    "gimbal, PD of a spring torque": (GIMBAL_TORQUE, ["X", "k1"]),
    "latch on the placed gimbal": (LATCH_PLACED, ["X", "k1"]),
    "gimbal on a prescribed base": (GIMBAL_CARRIED, ["X", "k1"]),
    "gimbal, an integral of its angles": (GIMBAL_INTEGRAL, ["X", "k1"]),
    "arm placed, a PI (per-step path)": (PI_ARM, ["X", "Kp"]),
    "arm placed, sampled at 50 Hz": (SAMPLED_ARM, ["X", "Kp"]),
}


def _once(data) -> tuple[float, float]:
    cpu, wall = time.process_time(), time.perf_counter()
    latdyn.run(latdyn.load_scene(data))
    return time.process_time() - cpu, time.perf_counter() - wall


def main(scenes: dict | None = None) -> None:
    """Measure ``scenes`` (name -> (scene, parameters); :data:`SCENES` unless given) and print each one's line."""
    for name, (text, parameters) in (SCENES if scenes is None else scenes).items():
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
