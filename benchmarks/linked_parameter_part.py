"""The linked models' parameter part of an event's weight beside controllers (issue 34): (∂K/∂p) w generated through
the reduction (latdyn/analyses/parameter_stiffness.py ``linked_controller_parameter_along``) against the central
difference of the static ∂r/∂p along w it replaces (``--before``: ``exact_parameters`` as on 0d1fc61, none exact on a
linked model beside controllers).

    python benchmarks/linked_parameter_part.py [--before] [--term] [--same] [--runs] [--cost]

``--same``: (∂K/∂p) w against Richardson-extrapolated differences of the same quantity (the static ∂r/∂p along w at
the assembled rates held; tests/test_weight_derivative_linked_parameters.py ``parameter_part_and_reference``);
``--term``: (∂K/∂p) w at a turned state with random rates against Richardson differences in p of the evaluation's
K w (tests/test_sensitivities_linked_controller_latch.py ``_stiffness_by_parameters``); ``--runs``: the whole runs'
sensitivities against Richardson central differences of whole runs (tests/test_sensitivities_events.py ``_agree``)
and the count of the difference's evaluations at the events; ``--cost``: CPU and wall of ``_stiffness_derivative``
at the events and of the whole forward run (medians of 5 after a warm-up)."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]   # the tests' scenes and helpers (tests/cli_runs.py is imported bare)

import latdyn  # noqa: E402
from latdyn.analyses import transient_sensitivities as ts  # noqa: E402
from tests.test_weight_derivative_linked_parameters import (BEAD_IN_TIME, SCENES, parameter_part_and_reference,  # noqa: E402
                                                          relative_errors, turned)


def before() -> None:
    """0d1fc61's ``exact_parameters``: none exact with rigid links or guides beside controllers."""
    exact = ts.exact_parameters

    def base(owner):
        if owner.model.links is not None and owner.controllers is not None:
            return np.zeros(len(owner.names), bool)
        return exact(owner)

    ts.exact_parameters = base


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", action="store_true", help="0d1fc61's exact_parameters (the difference)")
    parser.add_argument("--term", action="store_true", help="(∂K/∂p) w against Richardson differences in p")
    parser.add_argument("--same", action="store_true", help="(∂K/∂p) w against Richardson of the same quantity")
    parser.add_argument("--runs", action="store_true", help="whole runs against Richardson, the difference's count")
    parser.add_argument("--cost", action="store_true", help="CPU and wall of the weighings and the whole runs")
    args = parser.parse_args()
    if args.before:
        before()
    from tests.test_sensitivities_events import _agree
    from tests.test_sensitivities_linked_controller_latch import _stiffness_by_parameters

    calls, costs = [0], []
    held = ts.TransientSensitivities._advanced_at_held_rates
    stiffness = ts.TransientSensitivities._stiffness_derivative

    def counted(self, *a, **k):
        calls[0] += 1
        return held(self, *a, **k)

    def timed(self, *a, **k):
        c, w = time.process_time(), time.perf_counter()
        out = stiffness(self, *a, **k)
        costs.append((time.process_time() - c, time.perf_counter() - w))
        return out

    ts.TransientSensitivities._advanced_at_held_rates = counted
    ts.TransientSensitivities._stiffness_derivative = timed
    scenes = {**SCENES, "the guided mass, its follower moment in t": (BEAD_IN_TIME, ["stop"], ["Kc"])}
    for name, (text, events, parameters) in scenes.items():
        if args.term:
            names, computed, reference = _stiffness_by_parameters(text)
            largest = float(np.max(np.abs(reference)))
            errors = {p: float(np.max(np.abs(computed[:, c] - reference[:, c]))
                               / (float(np.max(np.abs(reference[:, c]))) or largest)) for c, p in enumerate(names)}
            print(name, "term", {p: f"{e:.2g}" for p, e in errors.items()}, flush=True)
        if args.same:
            owner, state, w = turned(text)
            computed = owner._stiffness_derivative(state, w)
            single, reference = parameter_part_and_reference(owner, state, w)
            names = owner.names
            print(name, "same quantity: generated",
                  {p: f"{e:.2g}" for p, e in relative_errors(names, computed, reference).items()}, "difference", {p: f"{e:.2g}" for p, e in relative_errors(names, single, reference).items()}, flush=True)
        if args.runs:
            calls[0] = 0
            result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
            kinds = [e["kind"] for e in result.summary["events"]]
            agree = {p: f"{_agree(result, text, p, tolerance=1.0, event_tolerance=1.0):.2g}" for p in parameters}
            print(name, kinds, "evaluations", calls[0], "agree", agree, flush=True)
        if args.cost:
            scene = yaml.safe_load(text)
            latdyn.run(latdyn.load_scene(scene))
            whole, one = [], []
            for _ in range(5):
                costs.clear()
                c, w = time.process_time(), time.perf_counter()
                latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
                whole.append((time.process_time() - c, time.perf_counter() - w))
                one.append((sum(x[0] for x in costs), sum(x[1] for x in costs), len(costs)))
            cpu, wall = np.median([x[0] for x in whole]), np.median([x[1] for x in whole])
            print(name, "cost: _stiffness_derivative at the events CPU %.2f ms wall %.2f ms (%d calls); "
                  "whole run CPU %.1f ms wall %.1f ms" % (1e3 * np.median([x[0] for x in one]),
                                                          1e3 * np.median([x[1] for x in one]), one[0][2],
                                                          1e3 * cpu, 1e3 * wall), flush=True)


if __name__ == "__main__":
    main()
