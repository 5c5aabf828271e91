"""Cost of the scenes of tests/test_sensitivities_states_rates.py (docs/performance.md, "Controller states reading
rates (issue 34)"): the run without sensitivities and the forward method (the adjoint refuses these scenes),
alternating, five rounds, medians of process time and wall time (one process, the kernels cached; a warm-up run of
each first). Run from the repository root: ``PYTHONPATH=. chrt -f 10 python benchmarks/states_rates_cost.py``."""
from __future__ import annotations

from benchmarks.forward_refusals_lifted_cost import forward_against_without
from tests.test_sensitivities_states_rates import GIMBAL_RATE, LATCH_RATE, SAMPLED_STOP, SAMPLED_VELOCITY, SLEW_RATE

SCENES = {"slewing-boom-PI-of-the-rate": SLEW_RATE, "gimbal-filtered-rate-PIDs": GIMBAL_RATE,
          "sampled-PD-of-a-velocity": SAMPLED_VELOCITY, "sampled-PD-beside-a-stop": SAMPLED_STOP,
          "PI-of-a-rate-beside-a-latch": LATCH_RATE}


def main() -> None:   # benchmarks/forward_refusals_lifted_cost.py's measure of the two kinds, no adjoint
    forward_against_without(SCENES)


if __name__ == "__main__":
    main()
