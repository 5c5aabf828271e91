"""Controllers' outputs that name t beside events in the sensitivities' loop of steps: what a gradient run costs, and
its equality (benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/controller_time_sensitivities_loop.py [--scene latch|stop|chain] [--repeats 5]
    python benchmarks/controller_time_sensitivities_loop.py --scene chain --check DIR
    python benchmarks/controller_time_sensitivities_loop.py --scene chain --user 5 [--trees ROOT_A,ROOT_B]

``--scene latch``: tests/test_sensitivities_in_loop_controller_states.py's TIMED_LATCH, the 3D wheel on a skew hinge
latching at 0.5 rad, its hinge driven by a feed-forward controller Kp (a0 + g sin 3t − θ) (1.1 s, dt = 0.01),
``[Kp, a0, g, k, EI]``. ``--scene stop``: its TIMED_STOP, the same controller beside the wheel's stop (two hits, 1.0 s).
``--scene chain``: its TIMED_CHAIN, a set point of t feeding a clipped controller with a term of t feeding a push on the
wheel, beside the latch, ``[Kp, a0, g, Kl, k, EI]``. The modes, the times and the ratios printed:
benchmarks/hinge_sensitivities_loop.py's docstring (the same functions).
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    from benchmarks.hinge_sensitivities_loop import _from_tests, main

    tests = "test_sensitivities_in_loop_controller_states"
    main({name: _from_tests(tests, f"TIMED_{name.upper()}") for name in ("latch", "stop", "chain")}, "latch", __doc__)
