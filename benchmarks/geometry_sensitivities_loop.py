"""Geometry parameters in the loop of steps in C: what a gradient run costs, and its equality
(benchmarks/hinge_sensitivities_loop.py's three modes on scenes with geometry parameters).

    python benchmarks/geometry_sensitivities_loop.py [--scene lattice|cantilever] [--repeats 5]
    python benchmarks/geometry_sensitivities_loop.py --scene lattice --check DIR
    python benchmarks/geometry_sensitivities_loop.py --scene lattice --user 5 [--trees ROOT_A,ROOT_B]

``--scene lattice``: tests/test_sensitivities_in_loop_geometry.py's 3D lattice pyramid (four legs of two elements,
a top joint with mass, gravity, a load in t, one hinged leg) by its top joint's coordinates ``[X, Y, H]`` over 0.4 s
(dt = 0.004, a row every 0.012 s). ``--scene cantilever``: the same file's planar cantilever by its length ``[L]``
over 0.5 s (dt = 0.005, a row every 0.02 s). The modes and what they print: benchmarks/hinge_sensitivities_loop.py
(in process: without sensitivities, forward, forward with every step from Python; ``--check``: sha-256 of the files
with the switch on and off; ``--user``: fresh ``latdyn run`` processes, tree by tree in each round).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _scene(name: str, t_end: str) -> str:
    sys.path += [str(ROOT), str(ROOT / "tests")]   # after PYTHONPATH: the build compared is the one it names
    from tests import test_sensitivities_in_loop_geometry as scenes

    text = getattr(scenes, name)
    old = "t_end: 0.06" if name == "LATTICE" else "t_end: 0.08"
    assert old in text
    return text.replace(old, f"t_end: {t_end}")


SCENES = {"lattice": lambda: _scene("LATTICE", "0.4"), "cantilever": lambda: _scene("CANTILEVER", "0.5")}


def main() -> None:
    sys.path.append(str(ROOT))
    from benchmarks.hinge_sensitivities_loop import as_a_user, check, in_process

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", choices=tuple(SCENES), default="lattice")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--check", metavar="DIR")
    parser.add_argument("--user", type=int, metavar="N")
    parser.add_argument("--trees", default=str(ROOT))
    args = parser.parse_args()
    text = SCENES[args.scene]()
    if args.check:
        check(text, args.check)
    elif args.user:
        as_a_user(text, args.user, args.trees.split(","))
    else:
        in_process(text, args.repeats)


if __name__ == "__main__":
    main()
