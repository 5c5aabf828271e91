"""Linked models with controllers, laws of t beside events and rigid links' own sections in the sensitivities' loop
of steps: what a gradient run costs, and its equality.

    python benchmarks/linked_control_sensitivities_loop.py [--scene pd|time|rho] [--repeats 5]
    python benchmarks/linked_control_sensitivities_loop.py --scene pd --check DIR
    python benchmarks/linked_control_sensitivities_loop.py --scene pd --user 5 [--trees ROOT_A,ROOT_B]

``--scene pd``: the slider-crank whose crank a PD controller drives, bouncing once off its guide's stop, by the gains,
the set point, the slider's mass and the guide's stiffness (tests/test_sensitivities_in_loop_linked_control.py
``CRANK_PD``), dt = 0.001 over 0.22 s. ``--scene time``: the 3D gimbal of rigid links latching at 0.279 s under a tip
load and a hinge torque of t (``GIMBAL_T``), over 1 s. ``--scene rho``: the 3D gimbal under gravity by its rigid
rings' section value among others (``GIMBAL_RHO``), over 1 s.

The modes are benchmarks/hinge_sensitivities_loop.py's (its module docstring): in process, the run without
sensitivities, the forward run and the forward run with every step from Python, CPU and wall; ``--check`` the
sha-256 of the files with the switch on and off; ``--user`` fresh ``latdyn run`` processes, each tree in turn.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names

from benchmarks.hinge_sensitivities_loop import main  # noqa: E402


def _pd() -> str:
    from tests.test_sensitivities_in_loop_linked_control import CRANK_PD

    return CRANK_PD.replace("dt: 0.005", "dt: 0.001")


def _time() -> str:
    from tests.test_sensitivities_in_loop_linked_control import GIMBAL_T

    return GIMBAL_T.replace("t_end: 0.4", "t_end: 1.0")


def _rho() -> str:
    from tests.test_sensitivities_in_loop_linked_control import GIMBAL_RHO

    return GIMBAL_RHO.replace("t_end: 0.3", "t_end: 1.0")


SCENES = {"pd": _pd, "time": _time, "rho": _rho}


if __name__ == "__main__":
    main(SCENES, "pd", __doc__)
