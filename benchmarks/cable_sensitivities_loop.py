"""Cables and energy probes in the loop of steps in C: what a gradient run costs, and its equality
(benchmarks/hinge_sensitivities_loop.py's three modes on scenes with cables, and one with energy and momentum probes).

    python benchmarks/cable_sensitivities_loop.py [--scene mast|weight|truss|spin] [--repeats 5]
    python benchmarks/cable_sensitivities_loop.py --scene mast --check DIR
    python benchmarks/cable_sensitivities_loop.py --scene mast --user 5 [--trees ROOT_A,ROOT_B]

``--scene mast``: tests/test_sensitivities_in_loop_cables.py's 3D mast braced by three pretensioned cables (one with
mass and three elements, one damped) by ``[EA, L, EI, rho]`` over 0.4 s (dt = 0.002, a row every 0.01 s).
``--scene weight``: the same file's weight on a damped cable with mass by ``[EA, c, L, rho, m]`` over 0.4 s.
``--scene truss``: examples/cable_deploying_truss.yaml with its cables' rest length held at 1.8 m, cut to 0.5 s, by
``[EA, EI]`` (taut and slack twice). ``--scene spin``: tests/test_sensitivities_energies.py's SPIN_3D (a 3D arm with a
hinged second beam and a joint body, spinning, by 11 parameters) with its kinetic, strain, potential and total energies
and its six momenta (not the external work and dissipated energy), over 0.4 s (dt = 0.005). The modes and what they print: benchmarks/hinge_sensitivities_loop.py.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _scenes():
    sys.path += [str(ROOT), str(ROOT / "tests")]   # after PYTHONPATH: the build compared is the one it names
    from tests import test_sensitivities_in_loop_cables as scenes

    return scenes


SCENES = {"mast": lambda: _scenes().MAST.replace("t_end: 0.1,", "t_end: 0.4,"),
          "weight": lambda: _scenes().WEIGHT.replace("t_end: 0.2,", "t_end: 0.4,"),
          "truss": lambda: _scenes().truss(reel=False),
          "spin": lambda: _spin()}


def _spin() -> str:
    sys.path += [str(ROOT), str(ROOT / "tests")]
    from tests.test_sensitivities_energies import SPIN_3D

    lines = [line for line in SPIN_3D.splitlines() if "external_work" not in line and "dissipated" not in line]
    text = "\n".join(lines) + "\n"
    assert "t_end: 0.04," in text
    return text.replace("t_end: 0.04,", "t_end: 0.4,")


if __name__ == "__main__":
    sys.path.append(str(ROOT))
    from benchmarks.hinge_sensitivities_loop import main

    main(SCENES, "mast", __doc__)
