"""Probes of a controller with states (its state, its output) in the sensitivities' loop of steps: what a gradient run
costs, and its equality (benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/controller_probe_sensitivities_loop.py [--scene boom|clipped|stop|load] [--repeats 5]
    python benchmarks/controller_probe_sensitivities_loop.py --scene boom --check DIR
    python benchmarks/controller_probe_sensitivities_loop.py --scene boom --user 5 [--trees ROOT_A,ROOT_B]

``--scene boom``: tests/test_sensitivities_in_loop_controller_integral2.py's BOOM_PROBED, the two-link 3D boom whose
elbow (a skew hinge) a PI on its angle drives, latching at 0.4 rad (1.0 s, dt = 0.01), the PI's integral and output
recorded, ``[Kp, Ki, a, k, EI]``. ``--scene clipped``: its BOOM_CLIPPED_PROBED, the PI clipped at [−0.5, 1.5], HHT-α.
``--scene stop``: its WHEEL_PROBED, the 3D wheel on a skew hinge driven by a PI on a filtered angle (two states, both
recorded, and the output) beside its stop (two hits, 1.0 s), ``[Kp, Ki, w, k, EI]``. ``--scene load``: its BOOM_LOAD,
BOOM_PROBED's PI driving a force and a moment in the tip's axes too. The modes, the times and the
ratios printed: benchmarks/hinge_sensitivities_loop.py's docstring (the same functions).
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    from benchmarks.hinge_sensitivities_loop import _from_tests, main

    tests = "test_sensitivities_in_loop_controller_integral2"
    scenes = {"boom": "BOOM_PROBED", "clipped": "BOOM_CLIPPED_PROBED", "stop": "WHEEL_PROBED", "load": "BOOM_LOAD"}
    main({name: _from_tests(tests, constant) for name, constant in scenes.items()}, "boom", __doc__)
