"""Hinge laws of the state and explicit time dependence beside events in the sensitivities' loop of steps: what a
gradient run costs, and its equality (benchmarks/hinge_sensitivities_loop.py's three modes on these scenes).

    python benchmarks/state_law_sensitivities_loop.py [--scene torque|time|arm|pd] [--repeats 5]
    python benchmarks/state_law_sensitivities_loop.py --scene torque --check DIR
    python benchmarks/state_law_sensitivities_loop.py --scene torque --user 5 [--trees ROOT_A,ROOT_B]

``--scene torque``: tests/test_sensitivities_in_loop_state_laws.py's BOOM_TORQUE, the planar two-panel boom deployed
by a torque k (θ₀ − θ) − c θ̇ and latching at π (1.4 s, dt = 0.005, a row every 0.01 s), ``[k, c, theta0]``.
``--scene time``: its BOOM_IN_TIME, the boom's spring k and damper c with a torque and a tip load of t beside the
latch, ``[k, c, F]``. ``--scene arm``: its ARM_3D_STATE over 0.3 s, the 3D arm whose hinge has a stiffness in θ, a
damping in θ̇ and a torque in θ, t and an input, ``[E, k, c, r, A]``. ``--scene pd``: its ARM_PD over 0.3 s, the 3D
arm slewed by a PD controller on its hinge's angle and rate, ``[E, Kp, Kd, ref]``. The modes, the times and the ratios printed:
benchmarks/hinge_sensitivities_loop.py's docstring (the same functions).
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _module(path: Path, name: str):
    """The module at ``path`` (read from this checkout whatever build PYTHONPATH names first)."""
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _scene(name: str) -> str:
    scenes = _module(ROOT / "tests" / "test_sensitivities_in_loop_state_laws.py", "state_law_scenes")
    if name == "torque":
        return scenes.BOOM_TORQUE
    if name == "time":
        return scenes.BOOM_IN_TIME
    if name == "pd":
        return scenes.ARM_PD.replace("t_end: 0.06", "t_end: 0.3")
    return scenes.ARM_3D_STATE.replace("t_end: 0.06", "t_end: 0.3")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", choices=("torque", "time", "arm", "pd"), default="torque")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--check", metavar="DIR")
    parser.add_argument("--user", type=int, metavar="N")
    parser.add_argument("--trees", default=str(ROOT))
    args = parser.parse_args()
    text = _scene(args.scene)
    modes = _module(ROOT / "benchmarks" / "hinge_sensitivities_loop.py", "hinge_sensitivities_loop")
    if args.check:
        modes.check(text, args.check)
    elif args.user:
        modes.as_a_user(text, args.user, args.trees.split(","))
    else:
        modes.in_process(text, args.repeats)


if __name__ == "__main__":
    main()
