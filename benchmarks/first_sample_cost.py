"""Sensitivities whose first sample and states' first rates read a moving start: the forward method's and the
adjoint's CPU time against the run without sensitivities, in process (docs/performance.md, "The first sample at a
moving start (issue 34)").

    python benchmarks/first_sample_cost.py [--repeats 5]

Scenes (tests/test_sensitivities_first_sample.py): the arm spun at the start under a PD sampled at 25 Hz of its hinge's
rate, one of its tip's velocity, a PI whose state integrates the hinge's rate, one integrating the tip's velocity (by
the spin's rate W and a gain), and the sampled PD of the hinge by the tip's place tx (a geometry parameter). Each scene
warm once per variant, then ``--repeats`` rounds alternating the run without sensitivities, the forward method and the
adjoint (benchmarks/adjoint_linked_cost.py ``compare``); medians of ``time.process_time`` and wall. Run under
``chrt -f 10`` on a loaded machine.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scenes() -> dict:
    """{name: YAML text}."""
    from tests.test_sensitivities_first_sample import GEOMETRY_RATE, MOVED

    return {**{f"{name} (W, gain)": text for name, text in MOVED.items()}, "sampled rate (tx, Kd)": GEOMETRY_RATE}


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    from benchmarks.adjoint_controller_states_cost import main

    main(scenes, __doc__)
