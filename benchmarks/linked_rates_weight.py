"""The linked weight's rates generated (issue 34; docs/performance.md, "The linked weight's rates generated
(issue 34)").

On the 3D scenes of tests/test_weight_derivative_linked_rates.py (the gimbal of rigid links on skew hinges latching: a
hinge whose K_jj moves with its rate, a torque of θ and θ̇, PDs mixing a hinge's angle and rate; the chain of rigid bays
latching twice with a PD of two points on the bays' bodies). ``part``: at each event the
blocks that moved from the reduced weight's difference to the generated part (W_X: the hinges of
``linked_rate_moving_hinges``, the couplings whose output mixes an angle and a rate and those of controllers reading
points), Pᵀ W_X P w's derivative along
each column's move — exact (the whole exact part less the exact part with W_X left out) and the single central
difference at the package's step (``linked_rest_product`` with W_X as W_rest, as before) — against Richardson at
1600/800/400 × that step (median / largest over the columns, relative to the reference's largest). ``runs``: the
whole runs' probe and event-time sensitivities against Richardson central differences of whole runs (h = 1e-3 |p|
and h/2). ``cost``: one event's ``_weight_derivative`` (repeated 20 times), CPU and wall, and the whole run in process
(medians of 5). Run ``runs`` and ``cost`` on each tree (PYTHONPATH) to compare; ``part`` needs the branch.

    python benchmarks/linked_rates_weight.py part|runs|cost
"""
from __future__ import annotations

import copy
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import latdyn  # noqa: E402
from latdyn.analyses import transient_sensitivities as ts  # noqa: E402
from latdyn.analyses import weight_derivative as wd  # noqa: E402
from tests.test_weight_derivative_linked_rates import SCENES  # noqa: E402

#: the parameters differenced in ``runs``, of each scene's solve.sensitivities (its first three where none is)
PARAMETERS = {"the outer hinge's PD of its angle and rate": ["Kp", "Kd", "m"]}


def _without_the_moved_blocks():
    """(hinges, couplings) masks of the linked W_gen before linkedrates: the hinges moving with their rate, the
    couplings whose output mixes an angle and a rate and those of controllers reading points left out."""
    from latdyn.assembly.control import ANGLE, RATE

    exact_couplings = wd.linked_exact_couplings

    def hinges(assembler):
        return wd.exact_hinges(assembler) & ~wd.linked_rate_moving_hinges(assembler)

    def couplings(assembler):
        out = exact_couplings(assembler).copy()
        control = assembler.control
        for e, a in enumerate(np.asarray(control.coupling_actuator)):
            k = int(control.actuator_controller[a])
            kinds = control.sensor_kind[control.sensor_start[k]:control.sensor_start[k + 1]]
            controller = control.controllers[k]
            joints = bool(np.all((kinds == ANGLE) | (kinds == RATE))) and len(kinds) == len(controller.reads)
            if not joints or not wd._mixed_curvature_vanishes(controller, tuple(np.flatnonzero(kinds == ANGLE)),
                                                              tuple(np.flatnonzero(kinds == RATE))):
                out[e] = False
        return out
    return hinges, couplings


def _richardson(term, h: float) -> np.ndarray:
    d1, d2, d3 = ((term(s) - term(-s)) / (2 * s) for s in (h, h / 2, h / 4))
    return (16 * (4 * d3 - d2) / 3 - (4 * d2 - d1) / 3) / 15


def part() -> None:
    old_hinges, old_couplings = _without_the_moved_blocks()
    method = ts.TransientSensitivities._linked_weight_derivative
    for name, text in SCENES.items():
        rows = []

        def measured(owner, state, w, dq, scale, mass, rates, rows=rows):
            result = method(owner, state, w, dq, scale, mass, rates)
            A = owner.assembler
            exact = wd.linked_configuration_tangent(A, state, w, dq, scale, mass)
            by_rates = wd.linked_rates_tangent(A, state, w)
            if by_rates is not None:
                exact = exact + scale * wd.times(by_rates, rates[0])
            with pytest.MonkeyPatch.context() as patch:
                patch.setattr(wd, "linked_exact_hinges", old_hinges)
                patch.setattr(wd, "linked_exact_couplings", old_couplings)
                exact = exact - wd.linked_configuration_tangent(A, state, w, dq, scale, mass)
                for c in range(dq.shape[1]):
                    step = owner._linked_move_step(dq, rates, c)
                    if step is None:
                        continue

                    def moved(eta, c=c):
                        ev = A.evaluate(owner._linked_move(state, dq, rates, c, eta), matrices=True)
                        return wd.linked_rest_product(A, ev, w, scale, mass)
                    single = (moved(step) - moved(-step)) / (2 * step)
                    reference = _richardson(moved, 1600 * step)
                    size = float(np.max(np.abs(reference)))
                    if size > 0.0:
                        rows.append((float(np.max(np.abs(single - reference))) / size,
                                     float(np.max(np.abs(exact[:, c] - reference))) / size))
            return result

        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(ts.TransientSensitivities, "_linked_weight_derivative", measured)
            latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
        single, exact = np.array(rows).T
        print(f"{name}: difference {np.median(single):.2g} / {single.max():.2g}, "
              f"exact {np.median(exact):.2g} / {exact.max():.2g} ({len(rows)} columns)")


def runs() -> None:
    for name, text in SCENES.items():
        data = yaml.safe_load(text)
        result = latdyn.run(latdyn.load_scene(data))
        listed = data["solve"]["sensitivities"]
        for p in [q for q in PARAMETERS.get(name, []) if q in listed] or listed[:3]:
            value = float(data["parameters"][p])

            def at(dp):
                moved = copy.deepcopy(data)
                moved["parameters"][p] = value + dp
                r = latdyn.run(latdyn.load_scene(moved))
                return {k: np.asarray(a, float) for k, a in r.probes.items()}, r.summary["events"][0]["t"]
            central = []
            for h in (1e-3 * abs(value), 5e-4 * abs(value)):
                (ahead, t_ahead), (behind, t_behind) = at(h), at(-h)
                central.append(({k: (ahead[k] - behind[k]) / (2 * h) for k in ahead}, (t_ahead - t_behind) / (2 * h)))
            worst = 0.0
            for k in central[0][0]:
                reference = (4 * central[1][0][k] - central[0][0][k]) / 3
                if np.max(np.abs(reference)) > 0.0:
                    worst = max(worst, float(np.max(np.abs(np.asarray(result.sensitivities[(k, p)]) - reference))
                                             / np.max(np.abs(reference))))
            t_reference = (4 * central[1][1] - central[0][1]) / 3
            t_error = abs(result.summary["event_sensitivities"][0]["dt"][p] - t_reference) / abs(t_reference)
            print(f"{name} {p}: probes {worst:.2g}, event time {t_error:.2g}")


def cost() -> None:
    method = ts.TransientSensitivities._weight_derivative
    for name, text in SCENES.items():
        data = yaml.safe_load(text)
        latdyn.run(latdyn.load_scene(data))
        calls = []

        def timed(self, *args, **kwargs):
            cpu, wall = time.process_time(), time.perf_counter()
            for _ in range(20):
                out = method(self, *args, **kwargs)
            calls.append(((time.process_time() - cpu) / 20, (time.perf_counter() - wall) / 20))
            return out

        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(ts.TransientSensitivities, "_weight_derivative", timed)
            latdyn.run(latdyn.load_scene(data))
        whole = []
        for _ in range(5):
            cpu, wall = time.process_time(), time.perf_counter()
            latdyn.run(latdyn.load_scene(data))
            whole.append((time.process_time() - cpu, time.perf_counter() - wall))
        event, run = np.median(calls, axis=0), np.median(whole, axis=0)
        print(f"{name}: event {1e3 * event[0]:.2f} ms CPU, {1e3 * event[1]:.2f} ms wall; "
              f"run {1e3 * run[0]:.1f} ms CPU, {1e3 * run[1]:.1f} ms wall")


if __name__ == "__main__":
    {"part": part, "runs": runs, "cost": cost}[sys.argv[1] if len(sys.argv) > 1 else "part"]()
