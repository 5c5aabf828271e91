"""Issue 34: the discrete adjoint beside a shift on a part that turns, through latches, rigid stops, friction, compliant
stops and controllers (docs/parameters.md, "Geometry parameters by the adjoint").

The forward method takes these since ringevents (tests/test_geometry_sensitivities_turning_events.py: against
Richardson-extrapolated central differences of whole runs) with two mends: the impulse weight's (∂K/∂p) w gains the
inertia forces' moment d × F_S turned with the anchor (``TransientSensitivities._shifts_turned``), and a controller's
sensed point no longer counts the shift twice (``ControllerTerms._shift_sensed``). The adjoint reuses both: its
impulse weight's Pᵀū is the forward method's (∂K/∂p) w with its reduction's geometric term
(``AdjointSensitivities._weight_derivative_transposed``: ``_geometric_derivative``, which holds ``_shifts_turned``),
and a controller's ∂f/∂s ∂s/∂X comes with ``residual_derivatives(...)ᵀ w``. Here its derivatives (every probe's end,
max and min, every event time's) are the forward method's, relative to each output's largest derivative (by X and k1).

Measured (load 6 to 11 on 2 cores; the numbers do not depend on it): with the boom as the forward method's tests type
it (EA 1e5) the ring offset's latch 1.35e-10, its two impacts 4.8e-11, the inner hinge point's latch 9.0e-11, the PD's
latch 8.3e-11, the PD of the outer ring's x 2.8e-10, the PI's 1.9e-10, the PD sampled at 50 Hz 2.75e-9 (the forward
method's own value moves by 3.7e-9 of the output's largest when k1's column is dropped), the load in t 2.0e-10, the
latched hinge's torque as a probe 1.35e-10, friction and the compliant stop 4.5e-12, the
guide's origin on the turning arm tip through its latch 1.6e-13; the pendulum's hinge point on the sliding cart through
its latch (tests/test_geometry_sensitivities_link_geometry.py CART_LATCH) 3.0e-10. The gimbal's gaps above 1e-10 are
round-off of the stiff boom, not a term left out: they are ≤ 4.5e-11 without the latch (the same scenes to 0.4 s) and
before it (1.5e-11 at 0.27 s), they move erratically with the boom's EA (the PI's 2.4e-9, 1.9e-9, 1.9e-10, 1.8e-9,
2.0e-9 at EA 0.96e5 … 1.04e5; the ring offset's 8.0e-11 … 2.2e-10), the forward method's own a1 by X at the PI's end
(EA 0.98e5) moves by 1.4e-9 of itself when k1's column is dropped (from 0.13 s, before the latch: the runs' multi-column round-off),
and with the boom 30 times softer (EA 3e3, :data:`SOFT`) every gap is ≤ 4.3e-11. The adjoint without
``_shifts_turned`` is 2.4e-5 (the PI) to 1.0e-3 off on those soft scenes (6.2e-4 on the ring offset's latch as typed).
So the gimbal's scenes are checked on the soft boom within 1e-10, the ring offset's latch as typed within 1e-9.

Guards: on int25 (0c9686f5) the adjoint already ran these scenes and agreed; nothing in it was missing. With
``AdjointSensitivities._shifts_turned`` returning zeros (the term at the latch and stop weights) every test here fails
but friction's and the compliant stop's (no impulse there: a guard of the smooth steps' Eᵀw)."""
from __future__ import annotations

import json

import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run
from tests.test_adjoint_events import _disagreement
from tests.test_adjoint_geometry_linked import _adjoint
from tests.test_geometry_sensitivities_turning_events import (GUIDE_LATCH, INNER_LATCH, PI_LATCH, POINT_PD_LATCH,
                                                                RING_LATCH, RING_PD_LATCH, RING_STOP, SOFT_SLIP)


def _soft(text: str) -> str:
    """``text`` (a gimbal of tests/test_geometry_sensitivities_turning_events.py) with its boom 30 times softer axially
    (EA 3e3): its events and derivatives alike, its round-off (module docstring) small."""
    softened = text.replace("boom: {EA: 1.0e5,", "boom: {EA: 3.0e3,")
    assert softened != text
    return softened


#: RING_PD_LATCH's outer hinge driven by a proportional controller of its angle sampled at 50 Hz (held outputs)
SAMPLED_LATCH = RING_PD_LATCH.replace('pd: {output: "Kp*(0.1 - a1) - Kd*r1"}', 'pd: {output: "Kp*(0.1 - a1)", rate: 50}')
#: the ring offset's latch beside a load on the inner ring that names t (the event's ∂r/∂t δt_e: adjoint_time)
TIMED_LOAD_LATCH = RING_LATCH.replace("loads:\n", 'loads:\n  - {at: inner, force: ["0.3*sin(8*t)", 0, 0.1]}\n')
assert "rate: 50}" in SAMPLED_LATCH and "sin(8*t)" in TIMED_LOAD_LATCH

#: the gimbal's scenes through events on the soft boom, and friction, the compliant stop and the guide as typed
SOFT = {"ring-offset-latch": _soft(RING_LATCH), "ring-offset-stop": _soft(RING_STOP),
        "hinge-point-latch": _soft(INNER_LATCH), "point-pd-latch": _soft(POINT_PD_LATCH), "pi-latch": _soft(PI_LATCH),
        "sampled-pd-latch": _soft(SAMPLED_LATCH), "load-in-t-latch": _soft(TIMED_LOAD_LATCH),
        "friction-and-compliant-stop": SOFT_SLIP, "guide-origin-latch": GUIDE_LATCH}
#: each scene's events (kinds), so that a run that missed one fails here rather than agreeing on less
EVENTS = {"ring-offset-latch": ["latch"], "ring-offset-stop": ["stop", "stop"], "hinge-point-latch": ["latch"],
          "point-pd-latch": ["latch"], "pi-latch": ["latch"], "sampled-pd-latch": ["latch"],
          "load-in-t-latch": ["latch"], "friction-and-compliant-stop": [], "guide-origin-latch": ["latch"]}
#: how the adjoint's derivatives may differ from the forward method's (each output's largest derivative)
BOUND = 1e-10
#: ... on the stiff boom as typed (EA 1e5; the ring offset's latch 1.35e-10, module docstring)
STIFF_BOUND = 1e-9


def _api(text: str):
    return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


@pytest.fixture(scope="module")
def runs():
    return {}


def _both(runs, text: str) -> tuple:
    """(forward, adjoint) of ``text`` through the API, run once per module."""
    if text not in runs:
        runs[text] = (_api(text), _api(_adjoint(text)))
    return runs[text]


@pytest.mark.parametrize("name", list(SOFT))
def test_the_adjoint_equals_the_forward_method_through_events_beside_a_turning_shift(runs, name):
    """Each probe's end, max and min and each event's time: within BOUND of the forward method's, by X and k1; the
    events the same (joint, kind, time) and those expected; X's derivatives not all zero. Measured (soft boom): the ring
    offset's latch 5.8e-12, its two impacts 1.5e-12, the hinge point's latch 4.0e-12, the PD of the point 5.0e-12, the
    PI 4.3e-11, the sampled PD 2.1e-11, the load in t 1.9e-11; friction and the compliant stop 4.5e-12, the guide's
    origin 1.6e-13 (as typed)."""
    forward, adjoint = _both(runs, SOFT[name])
    assert [event["kind"] for event in forward.summary["events"]] == EVENTS[name]
    assert adjoint.summary["events"] == forward.summary["events"]
    assert _disagreement(forward.summary, adjoint.summary, events=False) <= BOUND
    assert any(by["X"] != 0.0 for which in adjoint.summary["probe_sensitivities"].values() for by in which.values())


def test_the_adjoint_equals_the_forward_method_on_the_stiff_boom_through_its_latch(runs):
    """The ring offset's latch as the forward method's test types it (EA 1e5): within STIFF_BOUND (measured 1.35e-10;
    9.5e-11 … 2.2e-10 with EA 0.96e5 … 1.04e5)."""
    forward, adjoint = _both(runs, RING_LATCH)
    assert [event["kind"] for event in adjoint.summary["events"]] == ["latch"]
    assert _disagreement(forward.summary, adjoint.summary) <= STIFF_BOUND


def test_the_cli_equals_the_api_through_the_latch(runs, tmp_path):
    """``python -m latdyn run`` of the ring offset's latch (soft boom) with the adjoint: exit 0, summary.json's probe and
    event sensitivities ``latdyn.run``'s to the bit."""
    text = SOFT["ring-offset-latch"]
    completed, out = latdyn_run(tmp_path, _adjoint(text), quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    adjoint = _both(runs, text)[1]
    assert summary["probe_sensitivities"] == adjoint.summary["probe_sensitivities"]
    assert summary["event_sensitivities"] == adjoint.summary["event_sensitivities"]


def test_the_loop_of_steps_on_and_off_gives_the_same_adjoint_through_the_latch(monkeypatch):
    """The ring offset's latch (soft boom) by X and k1: the forward pass's smooth steps stored by the loop of steps (39
    of 41; the forward method's own columns refuse the loop beside this shift) and the reverse pass's native steps (39)
    give the Python path's derivatives and event time's derivatives to the bit."""
    from tests.test_adjoint_in_loop import _run as _run_switched

    text = _adjoint(SOFT["ring-offset-latch"])
    native, python = _run_switched(text, monkeypatch, True), _run_switched(text, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == native.native_reverse == native.summary["steps"] - 2
    assert python.summary["sensitivity_steps_in_loop"] == 0 and python.native_reverse == 0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
