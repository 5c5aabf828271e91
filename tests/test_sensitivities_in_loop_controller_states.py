"""Controllers' outputs that name t beside events in the sensitivities' loop of steps (issue 34 item 2;
csrc/sensitivity_loop.c ``explicit_time_columns``, latdyn/analyses/sensitivities_in_loop.py ``_time_refusal``): a
continuous controller whose output names t (a feed-forward set point of t) beside a latch or a stop moves ∂r/∂t, its
∂y/∂t through the actuators; that rate is compiled as the parameters' ∂f/∂p are (transient_sensitivities
``_controller_time_rates``, derivative_laws.ControllerPartials), the one C function both paths call, and the smooth
steps take the loop. The results are the per-step Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to
the bit, through the API and the CLI, and Richardson central differences of whole runs'. Controllers with states keep
the Python path (tests/test_sensitivities_in_loop_controllers2.py guards it)."""
from __future__ import annotations

import pytest

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_events import LATCH_3D, STOP_3D, _agree
from tests.test_sensitivities_events import _run as _run_only
from tests.test_sensitivities_in_loop_state_laws import _run, _same

#: tests/test_sensitivities_events.py's 3D wheel on a skew hinge latching at 0.5 rad, its hinge driven by a
#: feed-forward controller Kp (a0 + g sin 3t − θ): its gain, set point, amplitude, the hinge's spring and a section value
TIMED_LATCH = (LATCH_3D.replace("parameters: {k: 1.0,", "parameters: {Kp: 0.5, a0: 0.2, g: 0.3, k: 1.0,")
               .replace("rest_angle: 1.0, lock_at", 'rest_angle: 1.0, torque: "drv", lock_at')
               .replace("solve: {", 'controllers:\n  drv: {output: "Kp*(a0 + g*sin(3*t) - angle)"}\nsolve: {')
               .replace("sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [Kp, a0, g, k, EI]"))
#: the wheel's controller beside its stop (restitution 0.9, hit twice before 1 s)
TIMED_STOP = (STOP_3D.replace("t_end: 1.07", "t_end: 1.0").replace("restitution: 0.5", "restitution: 0.9")
              .replace("parameters: {k: 1.0,", "parameters: {Kp: 0.5, a0: 0.3, g: 0.3, k: 1.0,")
              .replace("rest_angle: 1.0, limits", 'rest_angle: 1.0, torque: "drv", limits')
              .replace("solve: {", 'controllers:\n  drv: {output: "Kp*(a0 + g*sin(3*t) - angle)"}\nsolve: {')
              .replace("sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [Kp, a0, g, k, EI]"))
#: the latching wheel turned by a chain: a set point of t, a clipped controller on the angle and the wheel's place with
#: a term of t, a push on the wheel in its own axes (tests/test_sensitivities_controllers.py's WHEEL, with a latch)
TIMED_CHAIN = (LATCH_3D.replace("parameters: {k: 1.0,", "parameters: {Kp: 0.5, a0: 0.2, g: 0.3, Kl: 3.0, k: 1.0,")
               .replace("rest_angle: 1.0, lock_at", 'rest_angle: 1.0, torque: "2*pd + 0.1", lock_at')
               .replace("solve: {", 'controllers:\n  lead: {output: "a0 + g*sin(3*t)"}\n'
                        '  pd: {output: "Kp*(lead - angle) - 0.5*(tip_x - 0.66) + 0.2*cos(5*t)", limits: [-5, 0.6]}\n'
                        '  push: {output: "Kl*(0.7 - tip_x) + 0.2*pd"}\n'
                        'loads:\n  - {at: wheel, force: [0, "0.2*push", 0], moment: ["0.05*push", 0, 0], frame: wheel}\n'
                        'solve: {')
               .replace("sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [Kp, a0, g, Kl, k, EI]"))
assert 'torque: "drv", lock_at' in TIMED_LATCH and "sin(3*t)" in TIMED_LATCH and "[Kp, a0, g, k, EI]" in TIMED_LATCH
assert 'torque: "drv", limits' in TIMED_STOP and "restitution: 0.9" in TIMED_STOP and "t_end: 1.0" in TIMED_STOP
assert "cos(5*t)" in TIMED_CHAIN and '"0.2*push"' in TIMED_CHAIN and "[Kp, a0, g, Kl, k, EI]" in TIMED_CHAIN


@pytest.mark.parametrize("text, event", [(TIMED_LATCH, "latch"), (TIMED_STOP, "stop"), (TIMED_CHAIN, "latch")],
                         ids=["feed-forward beside a latch", "feed-forward beside a stop", "chain of t beside a latch"])
def test_outputs_that_name_t_beside_events_take_the_loop(text, event, monkeypatch):
    """Every smooth step in the loop of steps (all but the events' and the landings after them), the Python path's
    sensitivities and event time derivatives to the bit: the 3D wheel's feed-forward controller beside its latch and
    beside its stop (two hits), and a chain of controllers of t (one clipped, one pushing the wheel) beside the latch."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps = native.summary["steps"]
    assert native.summary["time_loop"] == "compiled"
    assert steps - 5 <= native.summary["sensitivity_steps_in_loop"] < steps
    assert native.summary["event_sensitivities"][0]["kind"] == event
    _same(native, python)


def test_the_chain_of_t_through_the_cli_writes_the_python_paths_bytes(tmp_path):
    """``latdyn run`` of the chain beside the latch as a user types it: the smooth steps in the loop, and the same
    sensitivities.csv, probes.csv and summary's sensitivities as a run with the loop off."""
    completed, out = latdyn_run(tmp_path, TIMED_CHAIN)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["steps"] - 5 <= summary["sensitivity_steps_in_loop"]
    the_loop_off_writes_the_same(tmp_path, out)


def test_the_rate_in_t_agrees_with_central_differences():
    """The feed-forward's amplitude g moves the latch's time; its sensitivities (the loop's, ∂y/∂t δt in every smooth
    step after the latch) agree with Richardson-extrapolated central differences of whole runs."""
    result = _run_only(TIMED_LATCH, "g")
    assert result.summary["sensitivity_steps_in_loop"] > 0
    print("worst", _agree(result, TIMED_LATCH, "g", tolerance=1e-5, event_tolerance=1e-6))


def test_an_output_of_t_reading_an_input_takes_the_loop(monkeypatch):
    """A feed-forward of t without parameters that reads an input and pushes the wheel, beside the latch and the
    parameters' controller: its rate in t reaches a controller that reads an input, which the loop now reads too
    (tests/test_sensitivities_in_loop_controller_reads.py): the smooth steps in the loop, the Python path's bits."""
    text = (TIMED_LATCH.replace("solve: {", 'inputs: {u: 0.05}\nloads:\n  - {at: wheel, force: [0, "ff", 0]}\nsolve: {', 1)
            .replace('"Kp*(a0 + g*sin(3*t) - angle)"}', '"Kp*(a0 + g*sin(3*t) - angle)"}\n  ff: {output: "0.1*sin(4*t) + u"}'))
    assert 'ff: {output: "0.1*sin(4*t) + u"}' in text and 'force: [0, "ff", 0]' in text
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled" and native.summary["events"][0]["kind"] == "latch"
    assert native.summary["steps"] - 5 <= native.summary["sensitivity_steps_in_loop"] < native.summary["steps"]
    assert abs(native.summary["event_sensitivities"][0]["dt"]["g"]) > 0.0
    _same(native, python)
