"""A parameter inside a controller's output that reads an earlier controller's output, through rigid stops.

The wheel on a hinge out of the coordinate planes (tests/test_sensitivities_controllers.py), the set point
``lead = a0 + 0.3*angle`` read by ``pd = Kp*(lead - angle) - ...``, the hinge's torque ``Kt*pd + 0.1*Kt*Kt``, a
rigid stop at 0.2 rad (e = 0.8) hit twice. At each impact the forward method differences the static ∂r/∂p along the
jump's w (latdyn/analyses/transient_sensitivities.py ``_terms_beside_stiffness_along``): ∂pd/∂Kp = lead - angle, the
compiled partial (latdyn/analyses/derivative_laws.py ``ControllerPartials``) read lead from the scene's controller
outputs (codegen/laws.py ``_block``: a symbol named like a controller reads its output), which were left at the step's
values while the states moved: lead's move 0.3 ∂angle/∂q w was lost, and Kp was 1.3e-6 off Richardson differences
(fwdrefusals found it the same at difference steps 1e-4 and 1e-5, and on main 86d57d9), while the same physics
written without the chain, ``Kp*(a0 - 0.7*angle)``, was 1.6e-10 off. The compiled partials now take lead as their
argument, its value at the state they are evaluated at (tests/test_controller_outputs_as_arguments.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, the_loop_off_writes_the_same
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both
from tests.test_sensitivities_refusals_lifted2 import WHEEL_KT_STOPS, _richardson_error, _run

#: the wheel of tests/test_sensitivities_refusals_lifted2.py (WHEEL_KT_STOPS), differentiated by Kp and Kt
CHAINED = WHEEL_KT_STOPS.replace("sensitivities: [Kt, Kp, k]", "sensitivities: [Kp, Kt]")
#: the same physics without the chain: pd's output written with lead's law in it
DIRECT = CHAINED.replace("Kp*(lead - angle)", "Kp*(a0 - 0.7*angle)")
#: one impact (to 0.34 s)
ONE_STOP = CHAINED.replace("t_end: 0.4", "t_end: 0.34")
#: pd nonlinear in the chained output (Kp lead²), and lead reading the hinge's rate too
NONLINEAR = CHAINED.replace("Kp*(lead - angle)", "Kp*(lead - angle) + 0.5*Kp*lead*lead")
BY_RATE = (CHAINED.replace('lead: {output: "a0 + 0.3*angle"}', 'lead: {output: "a0 + 0.3*angle + 0.05*w"}')
           .replace("    angle: {hinge: arm.end, quantity: angle}\n",
                    "    angle: {hinge: arm.end, quantity: angle}\n    w: {hinge: arm.end, quantity: rate}\n"))
assert "0.5*Kp*lead*lead" in NONLINEAR and "0.05*w" in BY_RATE and "quantity: rate" in BY_RATE
assert "Kp*(lead - angle)" in CHAINED and "sensitivities: [Kp, Kt]" in CHAINED
assert "Kp*(a0 - 0.7*angle)" in DIRECT and "t_end: 0.34" in ONE_STOP


@pytest.mark.parametrize("text, events, tolerance", [(CHAINED, 2, 1e-8), (ONE_STOP, 1, 1e-8), (NONLINEAR, 2, 1e-6),
                                                     (BY_RATE, 2, 1e-6)],
                         ids=["two-stops", "one-stop", "nonlinear", "lead-by-rate"])
def test_a_gain_inside_an_output_reading_a_chained_output_agrees_with_richardson_through_stops(text, events,
                                                                                                tolerance):
    """Measured (every probe's worst over the rows, relative to its largest; the event times too): Kp 9.8e-10
    (before the outputs moved with the states 1.3e-6, off from the first impact's row on, ≤ 1e-10 before it), Kt
    2.4e-9 (the same before: its partial reads no chained output); one impact Kp 2.5e-10 (before 4.0e-7); pd
    nonlinear in lead 5.1e-8 (before 4.5e-5); lead reading the rate too 1.9e-8 (before 4.7e-6). Each fails before."""
    result = _run(text)
    assert [e["kind"] for e in result.summary["events"]] == ["stop"] * events
    assert _richardson_error(text, result, "Kp") <= tolerance


def test_the_chained_set_point_gives_the_sensitivities_of_the_same_law_written_out():
    """``lead`` read by pd and ``a0 + 0.3*angle`` written into pd's output are one law: the runs' probes agree to
    round-off (measured 1.1e-14), their sensitivities by Kp and Kt too (measured 6.9e-13 and 6.8e-13 relative; Kp
    1.3e-6 before, the chain's difference losing lead's move at the impacts: fails before)."""
    chained, direct = _run(CHAINED), _run(DIRECT)
    for probe in chained.probes:
        assert np.allclose(chained.probes[probe], direct.probes[probe], rtol=0, atol=1e-12)
        for name in ("Kp", "Kt"):
            a, b = chained.sensitivities[(probe, name)], direct.sensitivities[(probe, name)]
            assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max(), (probe, name)


def test_the_chained_set_point_is_the_same_with_the_loop_on_and_off_and_by_the_adjoint():
    """The loop of steps takes the smooth steps (38 of 42) to the per-step Python path's bits; the adjoint gives the
    forward method's (measured 2.3e-12, the same before the change: AdjointSensitivities is a TransientSensitivities
    and moved with it; this test and the CLI's pass before the change too)."""
    runs = runs_with_the_loop_on_and_off(CHAINED)
    assert_same_sensitivities(runs[True], runs[False], nonzero="each")
    assert runs[True].summary["sensitivity_steps_in_loop"] > 0
    forward, adjoint = _both(CHAINED)
    assert _adjoint_error(forward, adjoint) <= 1e-10


def test_the_chained_set_point_through_the_cli_equals_the_api(tmp_path):
    """``latdyn run`` of the scene: summary.json's probe and event sensitivities those of ``latdyn.run`` to the bit;
    the loop off in a fresh process writes the same files."""
    run, out = latdyn_run(tmp_path, CHAINED)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(CHAINED)))
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]
    assert summary["event_sensitivities"] == api.summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)
