"""Energies, momenta and the external work with guides in the sensitivities' loop of steps: what a gradient run costs,
and its equality (benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/guide_energy_sensitivities_loop.py [--scene bead|arm] [--repeats 5]
    python benchmarks/guide_energy_sensitivities_loop.py --scene arm --check DIR
    python benchmarks/guide_energy_sensitivities_loop.py --scene arm --user 5

The scenes of tests/test_sensitivities_guide_energies.py: ``bead`` its BEAD_3D (a bead on a skew rod turned about a
skew axis by a prescribed motion, on a damped spring and a guide force of t, under gravity and a load of t; kinetic,
total, the six momenta, the slide; 0.6 s, dt = 0.01, ``[k, c, m, rest, F, fg]``); ``arm`` its ARM_3D (a slider on a
skew guide at a flexible 3D arm's tip, a load of t on it and the guide's force of t; kinetic, total, P_y, H_z and the
external work; 0.3 s, dt = 0.005, ``tol: 1.0e-11``, ``[k, m, EI, F, fg]``). The scenes are read from this checkout's
test file. The modes, the times and the ratios printed: benchmarks/hinge_sensitivities_loop.py's docstring.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: this checkout's benchmarks/hinge_sensitivities_loop.py (its modes)
_SPEC = importlib.util.spec_from_file_location("hinge_sensitivities_loop", ROOT / "benchmarks" / "hinge_sensitivities_loop.py")
hinge_sensitivities_loop = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(hinge_sensitivities_loop)


def _scene(name: str):
    """The test file's scene ``name``, read from this checkout's file."""
    def text() -> str:
        import sys

        sys.path += [str(ROOT), str(ROOT / "tests")]
        spec = importlib.util.spec_from_file_location("guide_energy_scenes",
                                                      ROOT / "tests" / "test_sensitivities_guide_energies.py")
        scenes = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(scenes)
        return getattr(scenes, name)
    return text


SCENES = {"bead": _scene("BEAD_3D"), "arm": _scene("ARM_3D")}

if __name__ == "__main__":
    hinge_sensitivities_loop.main(SCENES, "arm", __doc__)
