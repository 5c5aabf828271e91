"""Cost of the scenes of tests/test_sensitivities_hinge_on_stop.py (docs/performance.md, "A hinge resting on its stop
(issue 34)"): the run without sensitivities and the forward method (the adjoint refuses a resting hinge), alternating,
five rounds, medians of process time and wall time (one process, the kernels cached; a warm-up run of each first).
Run from the repository root: ``PYTHONPATH=. chrt -f 10 python benchmarks/hinge_on_stop_cost.py``."""
from __future__ import annotations

from benchmarks.forward_refusals_lifted_cost import forward_against_without
from tests.test_sensitivities_hinge_on_stop import BOOM, GIMBAL, REBOUND, RELEASE

SCENES = {"boom-rests": BOOM, "boom-released": RELEASE, "boom-rebound-projected": REBOUND, "gimbal-ring-rests": GIMBAL}


def main() -> None:
    forward_against_without(SCENES)


if __name__ == "__main__":
    main()
