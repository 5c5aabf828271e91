"""A deployable square truss of 1000 bays and 10⁴ beam elements, built in code (latdyn.scene.builder).

Each bay adds four corner joints (massless bodies) at x = (i + 1)·a and ten members of one
element each: four longerons from the previous corners, four battens around the new square
and two diagonals (one on the top face, one on a side face). The longerons of every bay are
hinged at their start about the batten direction, with a preloaded spring (rest angle) and a
``lock_at`` latch, as the folding joints of a deployable mast; the first square is fixed.

    python examples/deployable_truss.py            # build + validate, print the time and the size
    python examples/deployable_truss.py --yaml OUT # also write the scene file

Prints the wall time of building the mapping and validating it with latdyn.load_scene.
"""
from __future__ import annotations

import argparse
import time

from latdyn.scene.builder import SceneBuilder, hinge

BAYS = 1000
PITCH = 0.5   # bay length a
WIDTH = 0.4   # side of the square cross-section
CORNERS = ((0.0, 0.0), (WIDTH, 0.0), (WIDTH, WIDTH), (0.0, WIDTH))


def corner(i: int, k: int) -> str:
    return f"c{i}_{k}"


def add_bay(b: SceneBuilder, i: int) -> None:
    """Bay i joins the square i (x = i·a) to the square i + 1."""
    x = (i + 1) * PITCH
    for k, (y, z) in enumerate(CORNERS):
        b.body(corner(i + 1, k), at=[x, y, z], mass=0.05)
    for k in range(4):
        # a longeron folds about the batten direction at its start (in the plane of its face)
        axis = [0.0, 0.0, 1.0] if k in (0, 2) else [0.0, 1.0, 0.0]
        b.beam(f"b{i}_long{k}", corner(i, k), corner(i + 1, k), "longeron",
               start=hinge(axis, stiffness=0.5, rest_angle=0.05, lock_at=0.05))
        b.beam(f"b{i}_batten{k}", corner(i + 1, k), corner(i + 1, (k + 1) % 4), "batten")
    b.beam(f"b{i}_diag_top", corner(i, 0), corner(i + 1, 1), "diagonal")
    b.beam(f"b{i}_diag_side", corner(i, 1), corner(i + 1, 2), "diagonal")


def truss(bays: int = BAYS) -> SceneBuilder:
    b = SceneBuilder(f"deployable truss, {bays} bays")
    b.section("longeron", EA=2.0e6, EIy=40.0, EIz=40.0, GJ=30.0, rhoA=0.08)
    b.section("batten", EA=1.0e6, EIy=20.0, EIz=20.0, GJ=15.0, rhoA=0.05)
    b.section("diagonal", EA=5.0e5, EIy=5.0, EIz=5.0, GJ=4.0, rhoA=0.02)
    for k, (y, z) in enumerate(CORNERS):
        b.body(corner(0, k), at=[0.0, y, z], fixed=True)
    b.bays(bays, add_bay)
    b.solve(analysis="modes", count=6)
    b.probe("tip_x", point=corner(bays, 2), quantity="displacement", component="x")
    return b


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bays", type=int, default=BAYS)
    parser.add_argument("--yaml", metavar="OUT", help="write the scene as YAML")
    args = parser.parse_args()
    t0 = time.perf_counter()
    builder = truss(args.bays)
    t1 = time.perf_counter()
    scene = builder.build()
    t2 = time.perf_counter()
    print(f"{scene.title}: {len(scene.bodies)} bodies, {len(scene.beams)} beams, {scene.n_elements} elements, "
          f"{len(scene.hinges)} hinges")
    print(f"built in {t1 - t0:.3f} s, validated in {t2 - t1:.3f} s: {t2 - t0:.3f} s in all")
    if args.yaml:
        builder.to_yaml(args.yaml)
        print(f"wrote {args.yaml}")


if __name__ == "__main__":
    main()
