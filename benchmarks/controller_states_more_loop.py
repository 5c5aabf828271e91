"""More controllers with states in the sensitivities' loop of steps (states reading points offset from their node or
in a body's axes, a prescribed body's beside an event, on models with rigid links or guides): what a gradient run
costs, and its equality (benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/controller_states_more_loop.py [--scene both|frame|gimbal|bead|stops|moment|tension] [--repeats 5]
    python benchmarks/controller_states_more_loop.py --scene both --check DIR
    python benchmarks/controller_states_more_loop.py --scene both --user 5 [--trees ROOT_A,ROOT_B]

The scenes are tests/test_sensitivities_in_loop_states_more.py's: ``--scene both`` BOOM_BOTH, the two-link 3D boom's
PI whose integral reads a point offset from the tip and a filter of that point's displacement in the elbow's axes,
latching at 0.4 rad (1.0 s, dt = 0.01, ``[Kp, Ki, a, k, EI]``); ``--scene frame`` BASE_FRAME, fuzz6's 3D boom whose
filter reads a point in the turning prescribed base's axes through a cable's taut event (0.2 s, ``[c1]``); ``--scene
gimbal`` GIMBAL_PI_LOAD, the 3D gimbal of two rigid rings whose PI drives the inner hinge and pushes the inner ring
(0.3 s, ``[Kp, Ki, a, k1, m, EI]``); ``--scene bead`` BEAD_PI, the slider-crank's guided bead driven by a PI beside
its stops (0.22 s, ``[Kp, ref, Ki, tau, m, k]``); ``--scene stops`` TORQUE_STOPS, a controller reading the 3D
arm's hinge torque, the hinge on compliant stops whose law's parameters move it (0.3 s, ``[kc, cc, Kt, F]``);
``--scene moment`` MOMENT_E, a controller on the 3D arm reading a moment and a torque of elements whose section values
E moves (0.3 s, ``[F, Ka, E]``); ``--scene tension`` CABLE_L, a clipped controller reading a skew cable's
tension, by its rest length and EA (five cable changes, ``[L, Kt, EA]``). The modes, the times and the ratios printed:
benchmarks/hinge_sensitivities_loop.py's docstring (the same functions).
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    from benchmarks.hinge_sensitivities_loop import _from_tests, main

    tests = "test_sensitivities_in_loop_states_more"
    scenes = {"both": "BOOM_BOTH", "frame": "BASE_FRAME", "gimbal": "GIMBAL_PI_LOAD", "bead": "BEAD_PI",
              "stops": "TORQUE_STOPS", "moment": "MOMENT_E",
              "tension": "CABLE_L"}
    main({name: _from_tests(tests, constant) for name, constant in scenes.items()}, "both", __doc__)
