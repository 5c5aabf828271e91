"""Cost of the scenes of tests/test_sensitivities_refusals_lifted2.py (docs/performance.md, "Forward refusals lifted
(issue 34)"): the run without sensitivities, the forward method and the adjoint, alternating, five rounds, medians of
process time and wall time (one process, the kernels cached; a warm-up run of each first). Run from the repository
root: ``PYTHONPATH=. chrt -f 10 python benchmarks/forward_refusals_lifted_cost.py``."""
from __future__ import annotations

import statistics
import time

import yaml

import latdyn
from tests.test_sensitivities_refusals_lifted2 import (BEAD_VELOCITY, CABLE_ENERGIES, GIMBAL_ENERGIES, GUIDE_KF_STOP,
                                                       GUIDE_VELOCITY, MASSIVE_CABLE_ENERGIES, WHEEL_KT_STOPS)

SCENES = {"guide-velocity-controller": GUIDE_VELOCITY, "bead-on-gimbal-velocity": BEAD_VELOCITY,
          "wheel-Kt-stops": WHEEL_KT_STOPS, "guide-Kf-stop": GUIDE_KF_STOP,
          "stay-energies": CABLE_ENERGIES, "massive-stay-energies": MASSIVE_CABLE_ENERGIES,
          "gimbal-energies-rho": GIMBAL_ENERGIES}
KINDS = ("without", "forward", "adjoint")


def variant(text: str, kind: str) -> dict:
    """The scene without ``solve.sensitivities``, as written (the forward method), or under the adjoint."""
    data = yaml.safe_load(text)
    if kind == "without":
        data["solve"].pop("sensitivities", None)
    elif kind == "adjoint":
        data["solve"]["sensitivity_method"] = "adjoint"
    return data


def measure(text: str, rounds: int = 5, kinds: tuple = KINDS) -> dict:
    """{kind: (median CPU s, median wall s)} of the runs of ``text`` of each of ``kinds`` (the three), alternating."""
    times = {kind: ([], []) for kind in kinds}
    for kind in kinds:   # warm-up: the kernels and laws compiled and cached
        latdyn.run(latdyn.load_scene(variant(text, kind)))
    for _ in range(rounds):
        for kind in kinds:
            data = variant(text, kind)
            cpu, wall = time.process_time(), time.perf_counter()
            latdyn.run(latdyn.load_scene(data))
            times[kind][0].append(time.process_time() - cpu)
            times[kind][1].append(time.perf_counter() - wall)
    return {kind: (statistics.median(c), statistics.median(w)) for kind, (c, w) in times.items()}


def forward_against_without(scenes: dict) -> None:
    """Print, for each of ``scenes`` ({name: YAML text}), the run without sensitivities and the forward method
    (:func:`measure` of the two kinds): medians of CPU and wall time and the forward method's × the run without."""
    kinds = ("without", "forward")
    for name, text in scenes.items():
        med = measure(text, kinds=kinds)
        k = len(yaml.safe_load(text)["solve"]["sensitivities"])
        without, forward = (med[kind] for kind in kinds)
        print(f"{name} ({k} parameters): without {without[0] * 1e3:.0f} ms CPU ({without[1] * 1e3:.0f} wall); "
              f"forward {forward[0] * 1e3:.0f} ({forward[1] * 1e3:.0f}) = {forward[0] / without[0]:.2f} x CPU, "
              f"{forward[1] / without[1]:.2f} x wall", flush=True)


def all_three(scenes: dict) -> None:
    """Print, for each of ``scenes`` ({name: YAML text}), the run without sensitivities, the forward method and the
    adjoint (:func:`measure`): medians of CPU and wall time, × the run without and the adjoint's × the forward method."""
    for name, text in scenes.items():
        med = measure(text)
        k = len(yaml.safe_load(text)["solve"]["sensitivities"])
        without, forward, adjoint = (med[kind] for kind in KINDS)
        print(f"{name} ({k} parameters): without {without[0] * 1e3:.0f} ms CPU ({without[1] * 1e3:.0f} wall); "
              f"forward {forward[0] * 1e3:.0f} ({forward[1] * 1e3:.0f}) = {forward[0] / without[0]:.2f} x; "
              f"adjoint {adjoint[0] * 1e3:.0f} ({adjoint[1] * 1e3:.0f}) = {adjoint[0] / without[0]:.2f} x without, "
              f"{adjoint[0] / forward[0]:.2f} x forward", flush=True)


def main() -> None:
    all_three(SCENES)


if __name__ == "__main__":
    main()
