"""What an event's impulse weight derivative costs in the sensitivities: time and evaluations, forward and adjoint.

    python benchmarks/event_weight_cost.py [--scene lattice_latch|boom_latch] [--parameters 1,10,100]

Runs the latching scenes of benchmarks/transient_sensitivities_cost.py (``lattice_latch``: the 9-bay truss, 223
coordinates, its members' EA the parameters; ``boom_latch``: the planar boom of 50 elements) with ``k`` parameters
by the forward method twice and then by the adjoint, in one process, and prints for each run the time spent in the
weight derivative (``TransientSensitivities._weight_derivative``, ``AdjointSensitivities._weight_derivative_transposed``)
and the evaluations of the equations of motion made inside it (``Assembler.evaluate``). The first forward run of a
process also opens the ON_DEMAND kernel libraries (``beam_stiffness_D_q``: ≈ 0.12 s); the second and the adjoint are
warm. Figures: docs/parameters.md, "The discrete adjoint" (the latching lattice) and "The impulse weight's
derivative".
"""
from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import latdyn  # noqa: E402
from benchmarks.transient_sensitivities_cost import adjoint, latching_boom, lattice_latch  # noqa: E402
from latdyn.analyses.adjoint_sensitivities import AdjointSensitivities  # noqa: E402
from latdyn.analyses.transient_sensitivities import TransientSensitivities  # noqa: E402
from latdyn.assembly.assembler import Assembler  # noqa: E402


class Meter:
    """Counts the evaluations and the time inside the two weight derivatives (patched in for the process)."""

    def __init__(self):
        self.inside, self.evaluations, self.seconds, self.calls = False, 0, 0.0, 0
        evaluate = Assembler.evaluate

        def counted(assembler, *args, **kwargs):
            self.evaluations += self.inside
            return evaluate(assembler, *args, **kwargs)

        Assembler.evaluate = counted
        for owner, name in ((TransientSensitivities, "_weight_derivative"),
                            (AdjointSensitivities, "_weight_derivative_transposed")):
            setattr(owner, name, self.timed(getattr(owner, name)))

    def timed(self, method):
        @functools.wraps(method)
        def measured(owner, *args, **kwargs):
            self.inside, self.calls = True, self.calls + 1
            start = time.perf_counter()
            try:
                return method(owner, *args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start
                self.inside = False
        return measured

    def reset(self):
        self.evaluations, self.seconds, self.calls = 0, 0.0, 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", choices=("lattice_latch", "boom_latch"), default="lattice_latch")
    parser.add_argument("--parameters", default="1,10,100", help="comma-separated parameter counts")
    args = parser.parse_args()
    make = {"lattice_latch": lattice_latch, "boom_latch": latching_boom}[args.scene]
    meter = Meter()
    for k in (int(count) for count in args.parameters.split(",")):
        for method in ("forward", "forward", "adjoint"):
            data = make([f"F{i}" for i in range(k)])
            scene = latdyn.load_scene(adjoint(data) if method == "adjoint" else data)
            meter.reset()
            start = time.perf_counter()
            latdyn.run(scene)
            wall = time.perf_counter() - start
            print(f"{args.scene} {k:4d} parameters, {method:7s}: run {wall:6.2f} s; weight derivative {meter.calls} "
                  f"call(s), {meter.evaluations} evaluations, {meter.seconds * 1e3:7.1f} ms "
                  f"(load {os.getloadavg()[0]:.1f})", flush=True)


if __name__ == "__main__":
    main()
