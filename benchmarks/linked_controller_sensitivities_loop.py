"""Controllers on models with rigid links or guides in the sensitivities' loop of steps (points' sensors on dependent
nodes, chains, loads on rigid links' bodies, sampled controllers, a guided bead): what a gradient run costs, and its
equality.

    python benchmarks/linked_controller_sensitivities_loop.py [--scene point|chain|sampled|bead] [--repeats 5]
    python benchmarks/linked_controller_sensitivities_loop.py --scene point --check DIR
    python benchmarks/linked_controller_sensitivities_loop.py --scene point --user 5 [--trees ROOT_A,ROOT_B]

The scenes are tests/test_sensitivities_in_loop_linked_controllers.py's, read from this checkout's file (whatever
build PYTHONPATH names first). ``--scene point``: ``LATCHING_PD``, the 3D gimbal of rigid rings whose inner hinge a PD
controller on the outer ring's place and velocity and the inner ring's place in the outer's axes drives, latching at
−0.1 rad, over 1 s (dt = 0.01). ``--scene chain``: ``CHAIN``, an estimator feeding a PD clipped at ±0.3 feeding a push
on the inner ring, over 1 s. ``--scene sampled``: ``SAMPLED``, a digital controller at 50 Hz on the inner angle and the
outer ring's place, over 1 s. ``--scene bead``: ``BEAD``, the slider-crank's guided bead between its stops, a
controller on its slide, rate and the crank pin's place driving the crank, the guide and a force on the bead, dt =
0.001 over 0.22 s.

The modes are benchmarks/hinge_sensitivities_loop.py's (its module docstring): in process, the run without
sensitivities, the forward run and the forward run with every step from Python, CPU and wall; ``--check`` the
sha-256 of the files with the switch on and off; ``--user`` fresh ``latdyn run`` processes, each tree in turn.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names

from benchmarks.hinge_sensitivities_loop import main  # noqa: E402


def _scene(name: str, *changes: tuple[str, str]):
    """The test file's scene ``name`` (read from this checkout, its helpers from the build's tests) with ``changes``."""
    def text() -> str:
        path = ROOT / "tests" / "test_sensitivities_in_loop_linked_controllers.py"
        spec = importlib.util.spec_from_file_location("linked_controller_scenes", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        scene = getattr(module, name)
        for old, new in changes:
            assert old in scene, (name, old)
            scene = scene.replace(old, new)
        return scene
    return text


SCENES = {"point": _scene("LATCHING_PD", ("t_end: 0.4", "t_end: 1.0")),
          "chain": _scene("CHAIN", ("t_end: 0.3", "t_end: 1.0")),
          "sampled": _scene("SAMPLED", ("t_end: 0.3", "t_end: 1.0")),
          "bead": _scene("BEAD", ("dt: 0.005", "dt: 0.001"))}


if __name__ == "__main__":
    main(SCENES, "point", __doc__)
