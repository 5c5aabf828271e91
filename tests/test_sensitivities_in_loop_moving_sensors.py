"""A controller's state whose sensor the prescribed motion moves, through an event (issue 34; fuzz6's finding 3,
tests/test_fuzz_run_findings5.py item 2).

After an event every step ends at t + δt_e, so a sensor that moves with the prescribed motion at fixed free
coordinates (a prescribed body's position, a cable's length from a moving anchor) moves by ∂s/∂t δt there: the
states' δS_{n+1}, δf_{n+1} take it (ControllerStates._sensed), and the residual's ∂r/∂t through the prescribed motions
is evaluated with the states condensed as in the step (TransientSensitivities.step_columns; csrc/sensitivity_loop.c
``prescribed_time_rate`` the same). Before, the loop took the scene below (49 of 51 steps) and both paths were 3.5e-5
off Richardson differences (4903cb4); the loop then declined it for a while, and takes it again since (δt is 0 at
every step the loop takes, where ∂s/∂t δt is nothing: tests/test_sensitivities_in_loop_states_more.py)."""
from __future__ import annotations

import numpy as np

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_fuzz_run_findings5 import TAUT_STATE, _rows_against_richardson
from tests.test_sensitivities_in_loop_state_laws import _run

#: fuzz6 boom s6-11 with its filter state on the prescribed base's x (a point probe of the base) instead of the
#: cable's length, the output 20 Kr bx − 0.4 Sf; the cable's taut event at 0.12 s
BASE_STATE = (TAUT_STATE.replace("states: {Sf: wf*(span - Sf)}", "states: {Sf: wf*(bx - Sf)}")
              .replace("output: Kr*span - 0.4*Sf", "output: 20*Kr*bx - 0.4*Sf")
              .replace("    span: {cable: tie, quantity: length}\n",
                       "    span: {cable: tie, quantity: length}\n    bx: {point: base, quantity: position, component: x}\n"))
assert "states: {Sf: wf*(bx - Sf)}" in BASE_STATE and "bx: {point: base" in BASE_STATE


def test_a_state_on_a_prescribed_bodys_position_through_an_event_agrees_with_richardson_differences(monkeypatch):
    """Measured 4.9e-9 (3.5e-5 before, in the loop and on the Python path alike)."""
    native = _run(BASE_STATE, monkeypatch, True)
    assert [e["kind"] for e in native.summary["events"]] == ["taut"]
    assert native.summary["sensitivity_steps_in_loop"] == 49   # all but the event's step and the landing after it
    assert _rows_against_richardson(BASE_STATE, "c1") < 1e-7


def test_a_state_on_a_prescribed_bodys_position_through_an_event_by_the_command(tmp_path):
    """Through the command: the loop takes it, and the files are those of the loop switched off, byte for byte."""
    run, out = latdyn_run(tmp_path, BASE_STATE)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] == summary["steps"] - 2 and summary["steps"] > 40, summary["steps"]
    the_loop_off_writes_the_same(tmp_path, out)
    columns = np.loadtxt(out / "sensitivities.csv", delimiter=",", skiprows=1)
    assert np.all(np.isfinite(columns)) and np.abs(columns[:, 1:]).max() > 0


def test_a_state_on_a_free_angle_beside_an_output_on_the_prescribed_body_takes_the_loop(monkeypatch):
    """The state's rate reads the free hinge's angle a2 and only the output reads the base's x: the loop takes it (49
    of 51 steps, the taut event's on the Python path), to the bit, and Richardson differences agree (measured
    3.7e-9)."""
    text = BASE_STATE.replace("states: {Sf: wf*(bx - Sf)}", "states: {Sf: wf*(a2 - Sf)}")
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == 49 and native.summary["steps"] == 51
    assert python.summary["sensitivity_steps_in_loop"] == 0
    for key in native.sensitivities:
        assert np.array_equal(np.asarray(native.sensitivities[key]), np.asarray(python.sensitivities[key])), key
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", True)
        assert _rows_against_richardson(text, "c1") < 1e-7
