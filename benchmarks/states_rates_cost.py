"""Cost of the scenes of tests/test_sensitivities_states_rates.py (docs/performance.md, "Controller states reading
rates (issue 34)"): the run without sensitivities and the forward method (the adjoint refuses these scenes),
alternating, five rounds, medians of process time and wall time (one process, the kernels cached; a warm-up run of
each first). Run from the repository root: ``PYTHONPATH=. chrt -f 10 python benchmarks/states_rates_cost.py``."""
from __future__ import annotations

import statistics
import time

import yaml

import latdyn
from tests.test_sensitivities_states_rates import GIMBAL_RATE, LATCH_RATE, SAMPLED_STOP, SAMPLED_VELOCITY, SLEW_RATE

SCENES = {"slewing-boom-PI-of-the-rate": SLEW_RATE, "gimbal-filtered-rate-PIDs": GIMBAL_RATE,
          "sampled-PD-of-a-velocity": SAMPLED_VELOCITY, "sampled-PD-beside-a-stop": SAMPLED_STOP,
          "PI-of-a-rate-beside-a-latch": LATCH_RATE}
KINDS = ("without", "forward")


def variant(text: str, kind: str) -> dict:
    """The scene without ``solve.sensitivities``, or as written (the forward method)."""
    data = yaml.safe_load(text)
    if kind == "without":
        data["solve"].pop("sensitivities", None)
    return data


def measure(text: str, rounds: int = 5) -> dict:
    """{kind: (median CPU s, median wall s)} of the runs of ``text``, alternating."""
    times = {kind: ([], []) for kind in KINDS}
    for kind in KINDS:   # warm-up: the kernels and laws compiled and cached
        latdyn.run(latdyn.load_scene(variant(text, kind)))
    for _ in range(rounds):
        for kind in KINDS:
            data = variant(text, kind)
            cpu, wall = time.process_time(), time.perf_counter()
            latdyn.run(latdyn.load_scene(data))
            times[kind][0].append(time.process_time() - cpu)
            times[kind][1].append(time.perf_counter() - wall)
    return {kind: (statistics.median(c), statistics.median(w)) for kind, (c, w) in times.items()}


def main() -> None:
    for name, text in SCENES.items():
        med = measure(text)
        k = len(yaml.safe_load(text)["solve"]["sensitivities"])
        without, forward = (med[kind] for kind in KINDS)
        print(f"{name} ({k} parameters): without {without[0] * 1e3:.0f} ms CPU ({without[1] * 1e3:.0f} wall); "
              f"forward {forward[0] * 1e3:.0f} ({forward[1] * 1e3:.0f}) = {forward[0] / without[0]:.2f} x", flush=True)


if __name__ == "__main__":
    main()
