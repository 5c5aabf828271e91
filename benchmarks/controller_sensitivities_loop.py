"""More controllers in the sensitivities' loop of steps (points' sensors, chains, load actuators): what a gradient run
costs, and its equality (benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/controller_sensitivities_loop.py [--scene slew|chain|wheel|sampled|beside] [--repeats 5]
    python benchmarks/controller_sensitivities_loop.py --scene chain --check DIR
    python benchmarks/controller_sensitivities_loop.py --scene chain --user 5 [--trees ROOT_A,ROOT_B]

``--scene slew``: tests/test_sensitivities_in_loop_controllers2.py's SLEW, the 3D arm slewed about its knee's skew
hinge by a PD controller on the hinge's angle and the tip's velocity (in the knee's axes and globally) that drives the
hinge's torque and a force and moment at the tip (0.3 s, dt = 0.005, a row every 0.01 s), ``[E, Kp, Kd, ref]``.
``--scene chain``: its CHAIN, an estimator feeding a PD controller clipped at ±3 feeding a controller that pushes the
tip. ``--scene wheel``: tests/test_sensitivities_controllers.py's WHEEL (0.5 s, dt = 0.01), a set point of t feeding a
clipped controller feeding a push on the wheel in its own axes, ``[Kp, a0, g, k, Kl]``. ``--scene sampled``: the
test file's SAMPLED, the arm's PD controller sampled at 50 Hz; ``--scene beside``: its SAMPLED_BESIDE, the continuous PD
beside a clipped digital controller at 40 Hz that drives the tip's load. The modes, the times and the
ratios printed: benchmarks/hinge_sensitivities_loop.py's docstring (the same functions).
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _modes():
    """benchmarks/hinge_sensitivities_loop.py (read from this checkout whatever build PYTHONPATH names first)."""
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    spec = importlib.util.spec_from_file_location("hinge_sensitivities_loop", ROOT / "benchmarks" /
                                                  "hinge_sensitivities_loop.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


if __name__ == "__main__":
    modes = _modes()
    modes.main({"slew": modes._from_tests("test_sensitivities_in_loop_controllers2", "SLEW"),   # noqa: SLF001
                "chain": modes._from_tests("test_sensitivities_in_loop_controllers2", "CHAIN"),   # noqa: SLF001
                "wheel": modes._from_tests("test_sensitivities_controllers", "WHEEL"),   # noqa: SLF001
                "sampled": modes._from_tests("test_sensitivities_in_loop_controllers2", "SAMPLED"),   # noqa: SLF001
                "beside": modes._from_tests("test_sensitivities_in_loop_controllers2", "SAMPLED_BESIDE")},   # noqa: SLF001
               default="slew", description=__doc__)
