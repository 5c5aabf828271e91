"""Cost of the scenes of tests/test_sensitivities_hinge_on_stop.py (docs/performance.md, "A hinge resting on its stop
(issue 34)"): the run without sensitivities and the forward method (the adjoint refuses a resting hinge), alternating,
five rounds, medians of process time and wall time (one process, the kernels cached; a warm-up run of each first).
Run from the repository root: ``PYTHONPATH=. chrt -f 10 python benchmarks/hinge_on_stop_cost.py``."""
from __future__ import annotations

import yaml

from benchmarks.forward_refusals_lifted_cost import measure
from tests.test_sensitivities_hinge_on_stop import BOOM, GIMBAL, REBOUND, RELEASE

SCENES = {"boom-rests": BOOM, "boom-released": RELEASE, "boom-rebound-projected": REBOUND, "gimbal-ring-rests": GIMBAL}
KINDS = ("without", "forward")


def main() -> None:
    for name, text in SCENES.items():
        med = measure(text, kinds=KINDS)
        k = len(yaml.safe_load(text)["solve"]["sensitivities"])
        without, forward = (med[kind] for kind in KINDS)
        print(f"{name} ({k} parameters): without {without[0] * 1e3:.0f} ms CPU ({without[1] * 1e3:.0f} wall); "
              f"forward {forward[0] * 1e3:.0f} ({forward[1] * 1e3:.0f}) = {forward[0] / without[0]:.2f} x CPU, "
              f"{forward[1] / without[1]:.2f} x wall", flush=True)


if __name__ == "__main__":
    main()
