"""Rigid links and guides in the sensitivities' loop of steps: what a gradient run costs, and its equality.

    python benchmarks/linked_sensitivities_loop.py [--scene crank|gimbal|chain|guided] [--repeats 5]
    python benchmarks/linked_sensitivities_loop.py --scene crank --check DIR
    python benchmarks/linked_sensitivities_loop.py --scene crank --user 5 [--trees ROOT_A,ROOT_B]

``--scene crank``: examples/slider_crank.yaml over 0.45 s (before its drive's kink at 0.5 s, which sensitivities refuse;
dt = 0.002, a row every 0.01 s) with parameters of five
kinds (the rod's EI and rhoA, the slider's mass, a load on it, its guide's spring and damper:
tests/test_sensitivities_in_loop_links.py ``_shipped_slider_crank``). ``--scene gimbal``: the 3D gimbal of two rigid
links carrying a flexible boom (tests/test_sensitivities_rigid_links.py) by its hinges' springs, damper and rest
angle, a body's mass, the tip load and the boom's EI, over 1 s. ``--scene chain``: the deploying chain of two rigid
bays latching twice, by k, c, m, EI, F, over 2 s. ``--scene guided``: the guided mass on a spring on a flexible 3D arm
by the guide's stiffness, damping and rest, the mass and EI, over 1 s.

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


def _crank() -> str:
    from tests.test_sensitivities_in_loop_links import _shipped_slider_crank

    return _shipped_slider_crank().replace("t_end: 0.2,", "t_end: 0.45,")


def _gimbal() -> str:
    from tests.test_sensitivities_in_loop_links import GIMBAL_JOINTS

    return GIMBAL_JOINTS.replace("t_end: 0.3", "t_end: 1.0")


def _chain() -> str:
    from tests.test_sensitivities_in_loop_links import CHAIN

    return CHAIN.replace("t_end: 0.5", "t_end: 2.0")


def _guided() -> str:
    from tests.test_sensitivities_in_loop_links import GUIDED

    return GUIDED.replace("t_end: 0.4", "t_end: 1.0")


SCENES = {"crank": _crank, "gimbal": _gimbal, "chain": _chain, "guided": _guided}


if __name__ == "__main__":
    main(SCENES, "crank", __doc__)
