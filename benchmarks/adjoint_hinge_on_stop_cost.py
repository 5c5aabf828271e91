"""Cost of the adjoint through a hinge resting on its stop, on the scenes of tests/test_adjoint_hinge_on_stop.py
(docs/performance.md, "The adjoint through a hinge resting on its stop (issue 34)"): the run without sensitivities, the
forward method and the adjoint, alternating, five rounds, medians of process time and wall time (one process, the
kernels cached; a warm-up run of each first; the geometry parameter zt left out, as the adjoint refuses it beside a
rest). Run from the repository root: ``PYTHONPATH=. chrt -f 10 python benchmarks/adjoint_hinge_on_stop_cost.py``."""
from __future__ import annotations

from benchmarks.forward_refusals_lifted_cost import all_three
from tests.test_adjoint_hinge_on_stop import SCENES, _without_geometry


def main() -> None:
    all_three({name: _without_geometry(text) for name, text in SCENES.items()})


if __name__ == "__main__":
    main()
