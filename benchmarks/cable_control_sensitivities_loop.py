"""Cables beside controllers and beside explicit time dependence in the loop of steps in C: what a gradient run costs, and
its equality (benchmarks/hinge_sensitivities_loop.py's three modes).

    python benchmarks/cable_control_sensitivities_loop.py [--scene mast_pd|mast_pushed|truss|gimbal] [--repeats 5]
    python benchmarks/cable_control_sensitivities_loop.py --scene mast_pd --check DIR
    python benchmarks/cable_control_sensitivities_loop.py --scene mast_pd --user 5 [--trees ROOT_A,ROOT_B]

The scenes are tests/test_sensitivities_in_loop_cables2.py's, read from this checkout's file (so that a build without
it, put first on PYTHONPATH, runs them too). ``--scene mast_pd``: the 3D mast hinged at its base, braced by three
pretensioned cables, its hinge driven by a PD controller, by ``[Kp, Kd, ref, EA, L, EI, rho]`` over 0.4 s (dt = 0.002,
a row every 0.01 s). ``--scene mast_pushed``: the same under a push of t at its top, its hinge torque the controller's
output plus a torque of t, over 0.4 s. ``--scene truss``: the shipped cable truss (rest length held at 2.6 m) under a
load of t at its tip station, latching at 0.55 s, its cables going taut and slack, by ``[EA, EI, F]`` over 0.8 s.
``--scene gimbal``: the PD-driven 3D gimbal of rigid links latching under a tip load of t (no cables). The modes and
what they print: benchmarks/hinge_sensitivities_loop.py.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _scenes():
    """tests/test_sensitivities_in_loop_cables2.py of this checkout (the modules it imports: the first on the path)."""
    sys.path += [str(ROOT), str(ROOT / "tests")]   # after PYTHONPATH: the build compared is the one it names
    spec = importlib.util.spec_from_file_location("cables2_scenes", ROOT / "tests" / "test_sensitivities_in_loop_cables2.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _longer(text: str) -> str:
    assert "t_end: 0.1," in text
    return text.replace("t_end: 0.1,", "t_end: 0.4,")


SCENES = {"mast_pd": lambda: _longer(_scenes().MAST_PD),
          "mast_pushed": lambda: _longer(_scenes().MAST_PD_PUSHED),
          "truss": lambda: _scenes().truss_pulled(),
          "gimbal": lambda: _scenes().GIMBAL_PD_PUSHED}


if __name__ == "__main__":
    sys.path.append(str(ROOT))
    from benchmarks.hinge_sensitivities_loop import main

    main(SCENES, "mast_pd", __doc__)
