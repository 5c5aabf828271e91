"""The work accounts and reels everywhere in the sensitivities' loop of steps: what a gradient run costs, and its
equality (benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/accounts_sensitivities_loop.py [--scene reel|laws|slewing|gimbal|guide|ring] [--repeats 5]
    python benchmarks/accounts_sensitivities_loop.py --scene slewing --check DIR
    python benchmarks/accounts_sensitivities_loop.py --scene slewing --user 5 [--trees ROOT_A,ROOT_B]

The scenes of tests/test_sensitivities_in_loop_accounts2.py: ``reel`` its REEL_PD_LATCH as it is (the 3D mast braced by
three cables, one reeled in, pushed by a load of t, its hinge driven by a PD plus a torque of t, latching; 0.3 s,
dt = 0.002, ``[Kp, Kd, ref, EA, L, EI, rho]``); ``laws`` its BOOM_LAWS over 1 s (the 3D boom, a damper c (1 + θ̇²), a
torque of θ and t, a spring of θ and t; both accounts; dt = 0.005, ``[EI, rho, k, c, F]``); ``slewing`` its
BOOM_SLEWING over 1 s (the boom's base slewing about a skew axis and translating; the external work with the drive's;
``tol: 1.0e-11``); ``gimbal`` its GIMBAL_WORK as it is (the 3D gimbal of rigid links, two loads, both accounts; 0.3 s,
dt = 0.01, ``[k1, k2, c2, m, P, EI]``); ``guide`` its GUIDED_LOST as it is (the guided mass on its damped skew guide,
the dissipated energy; 0.4 s, dt = 0.005, ``[k, c, m, EI]``, ``tol: 1.0e-11``); ``ring`` its GIMBAL_LOAD_ON_A_LINK
(the gimbal with its second load on the outer ring, a node the links carry; ``tol: 1.0e-11``). The scenes are read from this
checkout's test file whatever tree PYTHONPATH names (an older tree has no such file). The modes, the times and the
ratios printed: benchmarks/hinge_sensitivities_loop.py's docstring (the same functions).
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: this checkout's benchmarks/hinge_sensitivities_loop.py (its modes)
_SPEC = importlib.util.spec_from_file_location("hinge_sensitivities_loop", ROOT / "benchmarks" / "hinge_sensitivities_loop.py")
hinge_sensitivities_loop = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(hinge_sensitivities_loop)


def _scene(name: str, end: str = "", longer: str = ""):
    """The test file's scene ``name`` with ``end`` replaced by ``longer``, read from this checkout's file."""
    def text() -> str:
        import sys

        sys.path += [str(ROOT), str(ROOT / "tests")]   # after PYTHONPATH (the build compared); the tests' helpers
        spec = importlib.util.spec_from_file_location("accounts_scenes",
                                                      ROOT / "tests" / "test_sensitivities_in_loop_accounts2.py")
        scenes = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(scenes)
        return getattr(scenes, name).replace(end, longer) if end else getattr(scenes, name)
    return text


SCENES = {"reel": _scene("REEL_PD_LATCH"), "laws": _scene("BOOM_LAWS", "t_end: 0.1,", "t_end: 1.0,"),
          "slewing": _scene("BOOM_SLEWING", "t_end: 0.1,", "t_end: 1.0,"), "gimbal": _scene("GIMBAL_WORK"),
          "guide": _scene("GUIDED_LOST"), "ring": _scene("GIMBAL_LOAD_ON_A_LINK")}

if __name__ == "__main__":
    hinge_sensitivities_loop.main(SCENES, "slewing", __doc__)
