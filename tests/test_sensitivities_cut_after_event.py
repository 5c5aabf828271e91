"""The derivative of a step cut after Newton failed, right after an event (docs/parameters.md, "Events"; the
forward method's ``_step_size_derivative``, the adjoint's ``_size_rule``): with sensitivities the time loop
restarts at dt after an event and a landing on the grid, so a trial cut in half has the size of its trial halved,
δh = ½ δh_trial — 0 for a trial at the nominal dt, −½ δt_n for a trial shortened onto the grid point — not the
previous accepted step's δh scaled.

The scene: STOP_PLANAR's wheel latching at 0.5 rad (at 0.526 s, off the grid). Newton is made to fail twice on a
chosen trial after the latch (the first failure switches the inertia tangent on, the second cuts the step):
``TimeLoop._step`` reports that trial unconverged, the same in every run, so the runs of the differences take the
same steps. References: Richardson-extrapolated central differences of whole runs (k ± 1e-4 k, ± 5e-5 k), and
the adjoint equal to the forward method."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.timeloop.loop import TimeLoop
from tests.test_adjoint_events import STOP_PLANAR

LATCHING = STOP_PLANAR.replace("limits: [-10, 0.5],\n                      restitution: 0.5", "lock_at: 0.5")
PROBES = ("tip_y", "mid_y")
#: the integrator's step as the time loop takes it, unpatched
TAKEN = TimeLoop._step


def _run(monkeypatch, which: str, method: str = "forward", k: float = 4.0):
    """The latching run with sensitivities by k (``method``), Newton failing twice on ``which`` trial after the
    latch: "nominal" the first of size dt (at the grid point 0.53 s after the landing on it), "landing" the first
    (shortened onto the grid point 0.53 s)."""
    def failing(loop, h, t_new=None):
        new, stats = TAKEN(loop, h, t_new=t_new)
        failures = loop.__dict__.setdefault("_forced_failures", [0])
        chosen = which == "landing" or abs(h - loop.control.dt) < 1e-15
        if loop.model.locked.any() and failures[0] < 2 and chosen:
            failures[0] += 1
            stats = dataclasses.replace(stats, converged=False)
        return new, stats

    monkeypatch.setattr(TimeLoop, "_step", failing)
    # every step through TimeLoop._step, where the failure is made: the adjoint's forward pass and the forward
    # method's smooth steps (a hinge's k: latdyn/analyses/sensitivities_in_loop.py) held off the loop of steps in C
    # (latdyn/analyses/adjoint_in_loop.py), which would take the chosen trial without it
    monkeypatch.setattr("latdyn.analyses.adjoint_in_loop.ADJOINT_IN_LOOP", False)
    monkeypatch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", False)
    data = yaml.safe_load(LATCHING)
    data["parameters"]["k"] = k
    data["solve"].update(t_end=0.6, sensitivities=["k"], sensitivity_method=method)
    return latdyn.run(latdyn.load_scene(data))


@pytest.mark.parametrize("which", ["nominal", "landing"])
def test_a_step_cut_after_a_latch_agrees_with_richardson_forward_and_adjoint(monkeypatch, which):
    """The cut trial at dt (δh = 0; the rule h/h_prev · δh_prev gave 1.8e-2 off) and the cut trial onto the grid
    (δh = −½ δt_n): each probe's end derivative within 1e-7 of Richardson's (measured 2e-10), the adjoint the
    forward method's to 1e-10."""
    forward = _run(monkeypatch, which)
    assert [e["kind"] for e in forward.summary["events"]] == ["latch"]
    assert forward.summary["newton_cuts"] == 1 and forward.summary["cut_times"][0] > forward.summary["events"][0]["t"]
    adjoint = _run(monkeypatch, which, method="adjoint")
    k0 = 4.0
    estimates = []
    for step in (1e-4 * k0, 5e-5 * k0):
        up, down = _run(monkeypatch, which, k=k0 + step), _run(monkeypatch, which, k=k0 - step)
        estimates.append({p: (up.probes[p][-1] - down.probes[p][-1]) / (2 * step) for p in PROBES})
    for probe in PROBES:
        reference = (4 * estimates[1][probe] - estimates[0][probe]) / 3
        derivative = forward.summary["probe_sensitivities"][probe]["end"]["k"]
        scale = max(abs(reference), 1e-300)
        assert abs(derivative - reference) <= 1e-7 * scale, (probe, derivative, reference)
        assert abs(adjoint.summary["probe_sensitivities"][probe]["end"]["k"] - derivative) <= 1e-10 * scale
