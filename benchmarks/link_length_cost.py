"""Geometry changing a link's length (issue 34; docs/performance.md, "Geometry changing a link's length (issue 34)").

The cost of the sensitivities by a parameter that changes a rigid link's length or direction (the scenes of
tests/test_geometry_sensitivities_link_length.py: the gimbal's ring offset, its outer ring placed alone, gim1's end
point with gim2's length, the cart's pendulum lengthened) and, to compare, by a parameter that is not geometry (k1, k):
each scene's run in process without sensitivities, by its first parameter alone and by both, five rounds alternating
after one warm run, medians of CPU (``time.process_time``) and wall (benchmarks/geometry_links_cost.py ``main``). Run it
under ``chrt -f 10`` where the machine is loaded.

    python benchmarks/link_length_cost.py
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.geometry_links_cost import main  # noqa: E402  (the same rounds and medians)
from tests.test_geometry_sensitivities_link_length import CART_BOB, END_AND_LENGTH, OUTER, RING  # noqa: E402

#: name -> (scene, its parameters in the order measured: the first alone, then both)
SCENES = {
    "gimbal, k1 first": (RING, ["k1", "X"]),
    "the gimbal's ring offset (gim1's length)": (RING, ["X", "k1"]),
    "the outer ring placed alone (gim1's and gim2's lengths)": (OUTER, ["X", "k1"]),
    "gim1's end point with gim2's length": (END_AND_LENGTH, ["X", "k1"]),
    "cart, k first": (CART_BOB, ["k", "X"]),
    "the cart's pendulum lengthened": (CART_BOB, ["X", "k"]),
}


if __name__ == "__main__":
    main(SCENES)
