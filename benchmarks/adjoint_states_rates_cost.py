"""The discrete adjoint through controllers with states, and sampled ones, that read a rate: its CPU time against the
run without sensitivities and the forward method, in process (docs/performance.md, "The adjoint with states reading
rates (issue 34)").

    python benchmarks/adjoint_states_rates_cost.py [--repeats 5]

Scenes (tests/test_adjoint_states_rates.py): the slewing boom's PI with a filtered measurement of the hub's rate (5
parameters), the gimbal's two PIDs filtering the hinges' rates (5), the two-link boom's PID filtering the elbow's rate
through its latch (7), the wheel's PI filtering its rate beside two stops (5), the PD sampled at 50 Hz of the tip's
velocity beside a stop (3), the sampled filter of the hinge's rate beside a latch (3); and, measured in the same
minutes, the angle-reading twins of the first and the third (tests/test_adjoint_controllers_states.py SLEW_BOOM,
BOOM_LATCH). Each scene warm once per variant, then ``--repeats`` rounds alternating the run without sensitivities, the
forward method and the adjoint (benchmarks/adjoint_linked_cost.py ``compare``); medians of ``time.process_time`` and
wall. Run under ``chrt -f 10`` on a loaded machine.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scenes() -> dict:
    """{name: YAML text}."""
    from tests.test_adjoint_controllers_states import BOOM_LATCH, SLEW_BOOM
    from tests.test_adjoint_states_rates import LATCH_PID, SAMPLED_RATE_LATCH, SLEW_FILTERED, WHEEL_RATE_STOP
    from tests.test_sensitivities_states_rates import GIMBAL_RATE, SAMPLED_STOP

    return {"slewing boom, PI with a filtered rate (5 p)": SLEW_FILTERED,
            "gimbal, two PIDs filtering rates (5 p)": GIMBAL_RATE,
            "two-link boom, PID of a rate through a latch (7 p)": LATCH_PID,
            "wheel, PI filtering its rate beside two stops (5 p)": WHEEL_RATE_STOP,
            "sampled PD of a velocity beside a stop (3 p)": SAMPLED_STOP,
            "sampled filter of a rate beside a latch (3 p)": SAMPLED_RATE_LATCH,
            "twin: slewing boom, PI of the angle (3 p)": SLEW_BOOM,
            "twin: two-link boom, PI of the angle beside a latch (5 p)": BOOM_LATCH}


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    from benchmarks.adjoint_controller_states_cost import main

    main(scenes, __doc__)
