"""Cost of the scenes of tests/test_sensitivities_states_rates.py (docs/performance.md, "Controller states reading
rates (issue 34)"): the run without sensitivities and the forward method (the adjoint refuses these scenes),
alternating, five rounds, medians of process time and wall time (one process, the kernels cached; a warm-up run of
each first). Run from the repository root: ``PYTHONPATH=. chrt -f 10 python benchmarks/states_rates_cost.py``."""
from __future__ import annotations

import yaml

from benchmarks.forward_refusals_lifted_cost import measure
from tests.test_sensitivities_states_rates import GIMBAL_RATE, LATCH_RATE, SAMPLED_STOP, SAMPLED_VELOCITY, SLEW_RATE

SCENES = {"slewing-boom-PI-of-the-rate": SLEW_RATE, "gimbal-filtered-rate-PIDs": GIMBAL_RATE,
          "sampled-PD-of-a-velocity": SAMPLED_VELOCITY, "sampled-PD-beside-a-stop": SAMPLED_STOP,
          "PI-of-a-rate-beside-a-latch": LATCH_RATE}
KINDS = ("without", "forward")   # benchmarks/forward_refusals_lifted_cost.py's measure and variant, no adjoint


def main() -> None:
    for name, text in SCENES.items():
        med = measure(text, kinds=KINDS)
        k = len(yaml.safe_load(text)["solve"]["sensitivities"])
        without, forward = (med[kind] for kind in KINDS)
        print(f"{name} ({k} parameters): without {without[0] * 1e3:.0f} ms CPU ({without[1] * 1e3:.0f} wall); "
              f"forward {forward[0] * 1e3:.0f} ({forward[1] * 1e3:.0f}) = {forward[0] / without[0]:.2f} x", flush=True)


if __name__ == "__main__":
    main()
