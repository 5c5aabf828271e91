"""Geometry moving a link's own geometry (issue 34; docs/performance.md, "Geometry moving a link's own geometry (issue
34)").

The cost of the sensitivities by a parameter that moves a rigid link's start or end point or a guide's origin (the
scenes of tests/test_geometry_sensitivities_link_geometry.py: on bodies that never turn, the gimbal's first hinge point
on its fixed base and on a prescribed base, a cart's guide origin on the ground and on a fixed rail, the pendulum's
hinge point on the sliding cart, a carriage's guide origin on the cart; on parts that turn, the guide's origin on a
flexible arm's tip, the gimbal's inner hinge point and its first ring's end point on the outer ring) and, to compare,
by a parameter that is not geometry (k1, k): each scene's run in process without sensitivities, by its first
parameter alone and by both, five rounds alternating after one warm run, medians of CPU (``time.process_time``) and
wall (benchmarks/geometry_links_cost.py ``main``). Run it under ``chrt -f 10`` where the machine is loaded.

    python benchmarks/link_geometry_cost.py
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.geometry_links_cost import main  # noqa: E402  (the same rounds and medians)
from tests.test_geometry_sensitivities_link_geometry import (CART, CART_HINGE, END_OFFSET,  # noqa: E402
                                                             GIMBAL_HINGE_CARRIED, GIMBAL_HINGE_POINT, GUIDE_ORIGIN,
                                                             INNER_POINT, RAIL, TABLE)

#: name -> (scene, its parameters in the order measured: the first alone, then both)
SCENES = {
    "gimbal, k1 first": (GIMBAL_HINGE_POINT, ["k1", "X"]),
    "gimbal's hinge point on its fixed base": (GIMBAL_HINGE_POINT, ["X", "k1"]),
    "the same on a prescribed base": (GIMBAL_HINGE_CARRIED, ["X", "k1"]),
    "cart, k first": (CART, ["k", "X"]),
    "cart's guide origin on the ground": (CART, ["X", "k"]),
    "the same on a fixed rail": (RAIL, ["X", "k"]),
    "the pendulum's hinge point on the sliding cart": (CART_HINGE, ["X", "k"]),
    "a carriage's guide origin on the cart": (TABLE, ["X", "k"]),
    "guide on the arm's tip, k first": (GUIDE_ORIGIN, ["k", "X"]),
    "the guide's origin on the arm's tip (a part that turns)": (GUIDE_ORIGIN, ["X", "k"]),
    "the gimbal's inner hinge point on the outer ring (a part that turns)": (INNER_POINT, ["X", "k1"]),
    "the gimbal's first ring's end point on the outer ring (a part that turns)": (END_OFFSET, ["X", "k1"]),
}


if __name__ == "__main__":
    main(SCENES)
