"""What the gate on an event's rates term saves (issue 34; docs/performance.md, "An event's weight derivative along
the rates, gated").

At a latch or a stop the forward sensitivities take ∂(K w)/∂v δv, a central difference of K w along each parameter's
δv (``TransientSensitivities._stiffness_by_rates``: 2k evaluations), where K moves with the rates; which terms do is
asked of the model (``latdyn.analyses.weight_derivative.stiffness_moving_with_rates``, two evaluations). Before the
gate the difference was taken at every event. This runs the latching boom of benchmarks/transient_sensitivities_cost.py
(``latching_boom``: 50 tubes, a latch, parameters F0 … F<k−1>) with the gate ("gated") and with it held open ("always":
the former path, the predicate not asked), alternating, and prints per variant the medians of the run's wall and CPU
time, the Python-side evaluations (``Assembler.evaluate`` calls) and the CPU time inside the event's weight
derivatives, and whether the sensitivities are bit for bit the same.

    python benchmarks/event_rates_term_cost.py [--repeats 5] [--parameters 10,100]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import latdyn  # noqa: E402
from benchmarks.transient_sensitivities_cost import latching_boom  # noqa: E402
from latdyn.analyses.transient_sensitivities import TransientSensitivities  # noqa: E402
from latdyn.assembly.assembler import Assembler  # noqa: E402

GATED = TransientSensitivities.stiffness_moves_with_rates
EVALUATE = Assembler.evaluate
WEIGHT_DERIVATIVE = TransientSensitivities._weight_derivative
tally = {"evaluations": 0, "weight_cpu": 0.0}


def counted_evaluate(self, *args, **kwargs):
    tally["evaluations"] += 1
    return EVALUATE(self, *args, **kwargs)


def timed_weight_derivative(self, *args, **kwargs):
    start = time.process_time()
    try:
        return WEIGHT_DERIVATIVE(self, *args, **kwargs)
    finally:
        tally["weight_cpu"] += time.process_time() - start


def one(k: int, always: bool):
    """(wall, CPU, evaluations, weight-derivative CPU, result) of one run with ``k`` parameters."""
    TransientSensitivities.stiffness_moves_with_rates = (lambda self, state: True) if always else GATED
    scene = latdyn.load_scene(latching_boom([f"F{i}" for i in range(k)]))
    tally.update(evaluations=0, weight_cpu=0.0)
    wall, cpu = time.perf_counter(), time.process_time()
    result = latdyn.run(scene)
    return time.perf_counter() - wall, time.process_time() - cpu, tally["evaluations"], tally["weight_cpu"], result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--parameters", default="10,100", help="comma-separated counts k (default 10,100)")
    args = parser.parse_args()
    Assembler.evaluate = counted_evaluate
    TransientSensitivities._weight_derivative = timed_weight_derivative
    for k in (int(x) for x in args.parameters.split(",")):
        runs = {True: [], False: []}
        for _ in range(args.repeats):
            for always in (True, False):
                runs[always].append(one(k, always))
        gated, always = runs[False][-1][4], runs[True][-1][4]
        same = all(np.array_equal(gated.sensitivities[key], always.sensitivities[key]) for key in gated.sensitivities)
        for label, held in (("always", True), ("gated", False)):
            r = runs[held]
            print(f"k = {k:3d} {label:6s}: wall {statistics.median(x[0] for x in r):.3f} s, CPU "
                  f"{statistics.median(x[1] for x in r):.3f} s, evaluations {statistics.median(x[2] for x in r):.0f}, "
                  f"weight derivative CPU {statistics.median(x[3] for x in r):.4f} s (medians of {len(r)})")
        print(f"k = {k:3d} sensitivities bit for bit the same: {same}; 1-minute load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
