"""The dissipated energy's sensitivity in the sensitivities' loop of steps: what a gradient run costs, and its equality
(benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/work_sensitivities_loop.py [--scene boom|planar|stop] [--repeats 5]
    python benchmarks/work_sensitivities_loop.py --scene boom --check DIR
    python benchmarks/work_sensitivities_loop.py --scene boom --user 5 [--trees ROOT_A,ROOT_B]

``--scene boom``: tests/test_sensitivities_in_loop_work.py's BOOM_3D over 1 s (a 3D boom of two hinged beams with
springs and dampers, one damping a law in t, a tip load in t, gravity, a joint body, a spin; dt = 0.005, a row every
0.01 s), its dissipated energy, external work, a hinge angle and a tip coordinate probed, ``[EI, rho, k, c, F]``.
``--scene planar``: its PLANAR_ARM over 3 s (dt = 0.01, a row every 0.05 s), its dissipated energy, ``[c, EI, m]``.
``--scene stop``: its STOP_WORK as it is (the 3D wheel bouncing off its stop with restitution, a load on it; 1.07 s,
dt = 0.01), its external work, ``[F, k, c, J, m, EI, rho]``. The scenes are read from this checkout's
test file whatever tree PYTHONPATH names (an older tree has no such file). The modes, the times and the ratios
printed: benchmarks/hinge_sensitivities_loop.py's docstring (the same functions).
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: this checkout's benchmarks/hinge_sensitivities_loop.py (its modes)
_SPEC = importlib.util.spec_from_file_location("hinge_sensitivities_loop", ROOT / "benchmarks" / "hinge_sensitivities_loop.py")
hinge_sensitivities_loop = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(hinge_sensitivities_loop)


def _scene(name: str, end: str, longer: str):
    """The test file's scene ``name`` with its ``t_end`` replaced, read from this checkout's file."""
    def text() -> str:
        spec = importlib.util.spec_from_file_location("work_scenes", ROOT / "tests" / "test_sensitivities_in_loop_work.py")
        scenes = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(scenes)
        return getattr(scenes, name).replace(end, longer)
    return text


SCENES = {"boom": _scene("BOOM_3D", "t_end: 0.1", "t_end: 1.0"),
          "planar": _scene("PLANAR_ARM", "t_end: 0.3", "t_end: 3.0"),
          "stop": _scene("STOP_WORK", "t_end: 1.07", "t_end: 1.07")}

if __name__ == "__main__":
    hinge_sensitivities_loop.main(SCENES, "boom", __doc__)
