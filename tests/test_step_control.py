"""The adaptive step control's rules (latdyn/timeloop/control.py; docs/stepping.md, "Adaptive steps"): an accepted
step's own error estimate sizes the next step, h' = min(dt, max(dt_min, h · min(2, 0.9 e^(−1/3)))), taken before the
integrator accepts the step (after accept() a_n = a_{n+1} and the estimate reads 0: until 2026-11 the steps only
shrank on rejections, a sawtooth of rejected trials); after a step shortened onto a grid point the size proposed
before the shortening. Checked on the control itself against the formula (to round-off), and on the rigid pendulum
of tests/test_adaptive_error_norm.py through the CLI and the API: the rejected trials (106 with the old control, 14
measured now) and the final angle against the exact solution (8.0e-4 measured, error_tol 1e-5)."""
from __future__ import annotations

import json
import textwrap
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from scipy.integrate import solve_ivp

import latdyn
from latdyn.timeloop.control import StepControl
from tests.cli_runs import latdyn_run
from tests.test_adaptive_error_norm import RIGID_PENDULUM

SOLVE = SimpleNamespace(t_end=1.0, dt=0.1, dt_min=None, adaptive=True, error_tol=1e-3)


class Estimating:
    """An integrator whose error estimate is e · error_tol · length for the step it last took, and 0 once it has
    accepted that step (as GeneralizedAlpha's: a_n = a_{n+1})."""

    def __init__(self, error: float):
        self.error, self.accepted = error, False

    def error_estimate(self, h: float) -> float:
        return 0.0 if self.accepted else self.error * SOLVE.error_tol

    def accept(self) -> None:
        self.accepted = True


def _accept(control: StepControl, run, h: float, error: float, lands: bool = False) -> float:
    """One converged step of size ``h`` with relative estimate ``error`` through the loop's calls; the next size."""
    integrator = Estimating(error)
    assert not control.rejects(run, integrator, h)
    control.estimate_accepted(integrator, h)
    integrator.accept()
    run.state.t += h
    control.after_accepted(run, integrator, h, latched=False, stopped=False, lands=lands)
    return run.h


@pytest.mark.parametrize("error", [0.05, 0.3, 0.729, 0.9, 1.0])
def test_an_accepted_step_s_own_estimate_sizes_the_next_step(error):
    """h' = h · min(2, 0.9 e^(−1/3)): it shrinks after a step whose estimate is above 0.729 (no rejection in
    between), grows at most twofold, never beyond dt; ∂h'/∂h and ∂h'/∂e of the rule (Resize) as well."""
    control = StepControl(SOLVE, None, 1.0)
    run = SimpleNamespace(state=SimpleNamespace(t=0.0), h=0.04, rejected_steps=0)
    h = run.h
    expected = min(SOLVE.dt, h * min(2.0, 0.9 * error ** (-1 / 3)))
    assert _accept(control, run, h, error) == pytest.approx(expected, rel=1e-14)
    assert (run.h < h) == (error > 0.729 + 1e-12)
    factor = 0.9 * error ** (-1 / 3)
    if factor < 2.0:
        assert control.resize.by_step == pytest.approx(factor, rel=1e-14)
        assert control.resize.by_error == pytest.approx(-h * factor / (3 * error), rel=1e-14)
    assert run.rejected_steps == 0


def test_after_a_latch_and_after_a_step_shortened_onto_the_grid():
    """A latch or a stop restarts the accelerations: h' = 2h whatever the estimate; a step shortened onto a grid
    point hands on the size proposed before it (δh' = δh_proposed: Resize.by_proposed = 1)."""
    control = StepControl(SOLVE, None, 1.0)
    run = SimpleNamespace(state=SimpleNamespace(t=0.0), h=0.03, rejected_steps=0)
    integrator = Estimating(0.95)
    control.estimate_accepted(integrator, 0.03)
    control.after_accepted(run, integrator, 0.03, latched=True, stopped=False)
    assert run.h == 0.06
    run.state.t, run.grid_index = 0.09, 0   # 0.01 before the grid point 0.1: a step of 0.06 lands on it
    h, lands, t_new = control.next_step(run)
    assert lands and t_new == pytest.approx(0.1) and h == pytest.approx(0.01)
    assert _accept(control, run, h, 1e-4, lands=True) == 0.06
    assert control.resize.by_proposed == 1.0 and control.resize.by_step == control.resize.by_error == 0.0


def _pendulum(error_tol: float | None = None) -> dict:
    scene = yaml.safe_load(textwrap.dedent(RIGID_PENDULUM))
    if error_tol is not None:
        scene["solve"]["error_tol"] = error_tol
    return scene


def _exact_angle() -> float:
    k = 9.81 * 1.5 / (4.0 / 3.0)
    return solve_ivp(lambda t, y: [y[1], -k * np.cos(y[0])], (0.0, 2.0), [0.0, 0.0], rtol=1e-12, atol=1e-12).y[0, -1]


def test_the_rigid_pendulum_no_longer_sawtooths(tmp_path):
    """``latdyn run`` of the rigid pendulum (error_tol 1e-5): 140 steps, 14 trials rejected (106 with the estimate
    read after accept()), θ(2) within 8.0e-4 of the exact solution (8.3e-4 before); the API the same run."""
    run, out = latdyn_run(tmp_path, textwrap.dedent(RIGID_PENDULUM), quiet=True)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] > 100 and summary["rejected_steps"] <= 20
    result = latdyn.run(latdyn.load_scene(_pendulum()))
    assert (result.summary["steps"], result.summary["rejected_steps"]) == (summary["steps"], summary["rejected_steps"])
    assert abs(result.probes["a"][-1] - _exact_angle()) < 8.2e-4


# ----------------------------------------------------------------------------- fixed steps after a grid landing
FIXED = SimpleNamespace(t_end=1.0, dt=0.1, dt_min=None, adaptive=False, error_tol=1e-3)


def test_fixed_steps_grow_on_from_the_size_proposed_before_a_grid_landing():
    """Fixed steps recovering from a short step (an event's landing) double back to dt; a step shortened onto a grid
    point hands on the doubling of the size proposed before it, 2 · 0.03, not of the sliver it took, 2 · 0.01 (the
    sliver depends on where the event fell to the last digit, and doubling from it again and again made the steps,
    and the results, follow Newton's last iterates)."""
    control = StepControl(FIXED, None, 1.0)
    run = SimpleNamespace(state=SimpleNamespace(t=0.09), h=0.03, grid_index=0, rejected_steps=0)
    h, lands, t_new = control.next_step(run)
    assert lands and h == pytest.approx(0.01) and t_new == pytest.approx(0.1)
    run.state.t = t_new
    control.after_accepted(run, None, h, latched=False, stopped=False, lands=True)
    assert run.h == 0.06
    run.state.t, run.h, run.grid_index = 0.13, 0.06, 1   # a step landing short of the grid point 0.2: plain doubling, up to dt
    h, lands, _ = control.next_step(run)
    assert not lands and h == 0.06
    control.after_accepted(run, None, h, latched=False, stopped=False, lands=False)
    assert run.h == 0.1


PLANAR_TETHER = """\
title: planar arm on a hinge spring, tethered by a cable that goes taut and slack
sections: {arm: {EA: 1.0e6, EIy: 50.0, EIz: 50.0, GJ: 50.0, rhoA: 0.5}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  anchor: {at: [1, -1, 0], fixed: true}
  tip: {at: [1, 0, 0], mass: 0.2}
beams:
  arm: {from: base, to: tip, section: arm, elements: 3, start: {hinge: {axis: [0, 0, 1], stiffness: 5.0, rest_angle: 0.8}}}
cables:
  tether: {from: anchor, to: tip, EA: 500.0, rest_length: 1.2}
solve: {t_end: 1.0, dt: 0.005}
output:
  every: 0.005
  probes:
    angle: {hinge: arm.start, quantity: angle}
    tip_y: {point: tip, quantity: position, component: y}
    pull: {cable: tether, quantity: tension}
"""


def _largest_difference(a: dict, b: dict) -> float:
    """The largest difference of two runs' probes over their rows, relative to each probe's range in ``b``."""
    return max(float(np.max(np.abs(np.asarray(a[k]) - np.asarray(b[k]))) / np.ptp(b[k])) for k in b if k != "t")


def _at_tolerance(text: str, tol: float) -> dict:
    scene = yaml.safe_load(text)
    scene["solve"]["tol"] = tol
    return latdyn.run(latdyn.load_scene(scene)).probes


@pytest.mark.parametrize("scene", ["planar tether", "cable deploying truss"])
def test_a_run_through_cable_events_does_not_follow_newton_s_last_iterates(tmp_path, scene):
    """The steps after a cable's change land on grid points with slivers that depend on where the change fell to
    the last digit; doubling from each sliver again (instead of from the size proposed before it) kept the run off
    the nominal step, on a sequence of steps that jumps with Newton's last iterates. ``latdyn run`` at the default
    tolerance (1e-8) against the API at 1e-12, each probe's largest difference relative to its range: the planar
    tether (four changes in 1 s) 1.3e-2 before, 9.8e-11 now (its discretization error against dt/8: 1.4e-1 before
    and after); examples/cable_deploying_truss.yaml cut to 0.3 s (3D; the cables' taut and slack changes at 0.158
    and 0.274 s) 5.3e-3 before, 1.6e-8 now (against dt/2: 1.3e-2 before, 1.0e-2 now)."""
    from tests.cli_runs import probe_columns
    if scene == "planar tether":
        text = PLANAR_TETHER
    else:
        from tests.cli_runs import ROOT
        text = (ROOT / "examples" / "cable_deploying_truss.yaml").read_text().replace("t_end: 4.0", "t_end: 0.3")
    run, out = latdyn_run(tmp_path, text, quiet=True)
    assert run.returncode == 0, run.stderr
    default = probe_columns(out)
    assert json.loads((out / "summary.json").read_text())["cable_events"]
    assert _largest_difference(default, _at_tolerance(text, 1e-12)) < 1e-6


# ----------------------------------------------------------------------------- a landing whose retry fails
PI_HUB_LATCHING = """\
title: a PI loop on a hub that latches
parameters: {Kp: 6.0, Ki: 3.0}
sections: {s: {EA: 1.0e7, EIy: 1.0e5, EIz: 1.0e5, GJ: 1.0e5, rhoA: 0.1, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.5, 0, 0], mass: 4.0, inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: hub, to: tip, section: s, elements: 1,
        start: {hinge: {axis: [0, 0, 1], damping: 2.0, torque: "ctl", lock_at: 0.005}}}
controllers:
  ctl: {output: "-Kp*th - Ki*S", states: {S: "th"}, initial: {S: 0.2}}
loads:
  - {at: tip, moment: [0, 0, 0.8]}
solve: {t_end: 0.5, dt: 0.01}
output:
  every: 0.01
  probes:
    th: {hinge: arm.start, quantity: angle}
    S_ctl: {controller: ctl, state: S}
    u: {controller: ctl}
"""


def test_a_landing_whose_retry_fails_accepts_the_step_it_keeps(monkeypatch):
    """A step that crosses an event is shortened onto it; where the shortened retry fails Newton the landing keeps
    the step before it — and the accepted step must be that step whole: the integrator held the failed trial's
    continuous controller states (accepted with the step), evaluation and accelerations. The PI hub's latch at
    θ = 0.005 with its first retry made to fail must equal the run that takes the crossing step without landing
    (bit for bit, now; before, the controller's state S was 1.3e-5 and its output 3.8e-5 off after the latch)."""
    from latdyn.timeloop import loop

    def run(*patches):
        """The scene run with (object, attribute, replacement) patched in."""
        with monkeypatch.context() as patch:
            for target, name, value in patches:
                patch.setattr(target, name, value)
            return latdyn.run(latdyn.load_scene(yaml.safe_load(PI_HUB_LATCHING)))

    land, step, failed = loop.TimeLoop._land_on_event, loop.TimeLoop._step, []

    def landing(self, attempt):
        self._landing_now = True
        try:
            return land(self, attempt)
        finally:
            self._landing_now = False

    def failing_first_retry(self, h, t_new=None):
        new, stats = step(self, h, t_new)
        if getattr(self, "_landing_now", False) and not failed:
            failed.append(h)
            stats.converged = False
        return new, stats

    retry_failed = run((loop.TimeLoop, "_land_on_event", landing), (loop.TimeLoop, "_step", failing_first_retry))
    assert failed and retry_failed.summary["events"][0]["kind"] == "latch"
    not_landed = run((loop, "first_event", lambda *args, **kwargs: None))
    assert retry_failed.summary["events"] == not_landed.summary["events"]
    for name in ("th", "S_ctl", "u"):
        assert np.array_equal(retry_failed.probes[name], not_landed.probes[name]), name


# ----------------------------------------------------------------------------- adaptive steps before a grid point
def test_a_size_that_would_leave_a_sliver_before_a_grid_point_takes_half_the_way():
    """Adaptive steps: a proposed size h with the way left to the grid point between h and 2h takes half that way
    (the step after it reaches the grid point), instead of h and then a sliver; a size that reaches the grid point
    lands on it as before; fixed steps are untouched."""
    control = StepControl(SOLVE, None, 1.0)
    run = SimpleNamespace(state=SimpleNamespace(t=0.02), h=0.06, grid_index=0, rejected_steps=0)
    h, lands, t_new = control.next_step(run)
    assert (h, lands, t_new, control.halved) == (pytest.approx(0.04), False, None, True)
    run.state.t = 0.06
    h, lands, t_new = control.next_step(run)
    assert lands and h == pytest.approx(0.04) and t_new == pytest.approx(0.1) and not control.halved
    fixed = StepControl(FIXED, None, 1.0)
    run.state.t = 0.02
    assert fixed.next_step(run)[:2] == (0.06, False) and not fixed.halved


def test_the_planar_arm_no_longer_retries_the_proposed_size_after_a_sliver(tmp_path):
    """The planar arm of tests/test_sensitivities_adaptive.py (error_tol 3e-3) through ``latdyn run``: 45 steps,
    3 trials rejected (8 before, 6 of them the proposed size retried right after a sliver before a grid point),
    Newton iterations 203 -> 183; the API the same run; each probe within its accuracy against a fixed-step run at
    dt/64 (measured tip_x 2.3e-3, tip_y 1.1e-3, hinge 1.4e-2; 2.2e-3, 1.1e-3, 1.5e-2 before)."""
    from tests.cli_runs import probe_columns
    from tests.test_sensitivities_adaptive import PLANAR

    scene = yaml.safe_load(PLANAR)
    del scene["solve"]["sensitivities"]
    run, out = latdyn_run(tmp_path, yaml.safe_dump(scene), quiet=True)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["steps"], summary["rejected_steps"]) == (45, 3)
    result = latdyn.run(latdyn.load_scene(scene))
    assert (result.summary["steps"], result.summary["rejected_steps"]) == (45, 3)
    scene["solve"].update(adaptive=False, dt=scene["solve"]["dt"] / 64)
    reference = latdyn.run(latdyn.load_scene(scene))
    rows = [int(np.argmin(np.abs(reference.t - t))) for t in result.t]
    probes = probe_columns(out)
    for name, bound in (("tip_x", 2.5e-3), ("tip_y", 1.2e-3), ("hinge", 1.5e-2)):
        assert np.max(np.abs(probes[name] - reference.probes[name][rows])) < bound, name
