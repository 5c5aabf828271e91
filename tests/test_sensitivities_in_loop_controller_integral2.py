"""More of the continuous controllers with states in the sensitivities' loop of steps (issue 34 item 2; the first part:
tests/test_sensitivities_in_loop_controller_integral.py). Probes recording such a controller's state or output: the
loop carries each recorded row's δS and accepted S (csrc/controller_states.c ``controller_states_row``), which
SensitivityLoop.record_rows hands to TransientSensitivities.record as the per-step path's rows read them. And such
controllers beside sampled ones, and driving loads. The results
are the Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the API and the CLI."""
from __future__ import annotations

import pytest

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_in_loop_controller_integral import BOOM, BOOM_CLIPPED, BOOM_FILTER, WHEEL_STOP
from tests.test_sensitivities_in_loop_state_laws import _run, _same

#: probes of the PI's integral E and of its output (the elbow's torque)
PROBES = "  probes:\n    integral: {controller: ctl, state: E}\n    torque: {controller: ctl}\n"
#: the 3D boom's PI, its state and output recorded
BOOM_PROBED = BOOM.replace("  probes:\n", PROBES)
#: the same clipped under HHT-α (the output's probe 0 while clipped)
BOOM_CLIPPED_PROBED = BOOM_CLIPPED.replace("  probes:\n", PROBES)
#: the 3D wheel's PI on a filtered angle beside its stop, both states and the output recorded
WHEEL_PROBED = WHEEL_STOP.replace("  probes:\n", PROBES + "    filtered: {controller: ctl, state: F}\n")
#: the probed boom's shoulder driven by a digital P controller at 25 Hz clipped at ±1, recorded too, beside the PI
BOOM_SAMPLED = (BOOM_PROBED.replace('stiffness: "k", damping: 0.2}', 'stiffness: "k", damping: 0.2, torque: "dig"}')
                .replace("controllers:\n", 'controllers:\n  dig: {output: "Kd*(0.3 - shoulder)", rate: 25, limits: [-1, 1]}\n')
                .replace("Kp: 3.0,", "Kp: 3.0, Kd: 0.8,").replace("[Kp, Ki, a, k, EI]", "[Kp, Ki, a, k, EI, Kd]")
                .replace("    integral:", "    held: {controller: dig}\n    integral:"))
assert 'torque: "dig"' in BOOM_SAMPLED and "rate: 25" in BOOM_SAMPLED and "Kd]" in BOOM_SAMPLED and "held:" in BOOM_SAMPLED
#: the probed boom's PI driving a load at the tip too (a force and a moment in the tip's axes)
BOOM_LOAD = BOOM_PROBED.replace(
    "solve: {", 'loads:\n  - {at: tip, force: [0, 0, "0.2*ctl"], moment: ["0.05*ctl", 0, 0], frame: tip}\nsolve: {', 1)
#: the 3D wheel's PI on a filtered angle driving a load on the wheel too, beside its stop
WHEEL_LOAD = WHEEL_STOP.replace("solve: {", 'loads:\n  - {at: wheel, force: [0, "0.1*ctl", 0]}\nsolve: {', 1)
#: the boom's PI less a filtered tip height (a state reading a point) driving the tip's load alone, not the elbow
FILTER_LOAD_ONLY = BOOM_FILTER.replace('torque: "ctl", ', "").replace(
    "solve: {", 'loads:\n  - {at: tip, force: [0, "0.3*ctl", 0]}\nsolve: {', 1)
assert '"0.2*ctl"' in BOOM_LOAD and '"0.1*ctl"' in WHEEL_LOAD
assert '"0.3*ctl"' in FILTER_LOAD_ONLY and 'torque: "ctl"' not in FILTER_LOAD_ONLY
assert "integral:" in BOOM_PROBED and "integral:" in BOOM_CLIPPED_PROBED and "filtered:" in WHEEL_PROBED


@pytest.mark.parametrize("text, events", [(BOOM_PROBED, ["latch"]), (BOOM_CLIPPED_PROBED, ["latch"]),
                                          (WHEEL_PROBED, ["stop", "stop"]), (BOOM_SAMPLED, ["latch"]),
                                          (BOOM_LOAD, ["latch"]), (WHEEL_LOAD, ["stop", "stop"]),
                                          (FILTER_LOAD_ONLY, None)],
                         ids=["PI beside a latch", "clipped PI, HHT-alpha", "PI on a filter beside a stop",
                              "PI beside a sampled controller", "PI driving a load too", "wheel's PI driving a load",
                              "filtered PI driving a load alone"])
def test_probes_of_a_controller_with_states_take_the_loop(text, events, monkeypatch):
    """Probes of the states and the output of a controller with states: every smooth step in the loop of steps, the
    Python path's sensitivities (the probes' rows among them) and event time derivatives to the bit; beside a sampled
    controller too (its sample instants handed back to Python, its held output's δy carried between them); and
    such controllers driving loads (the point-load kernel through the actuated loads' columns, as
    ControllerTerms.add), beside a hinge torque or alone."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps = native.summary["steps"]
    assert native.summary["time_loop"] == "compiled"
    if events is None:   # no event: every step
        assert native.summary["sensitivity_steps_in_loop"] == steps
    else:
        assert steps - 2 * len(events) <= native.summary["sensitivity_steps_in_loop"] < steps
        assert [event["kind"] for event in native.summary["events"]] == events
    _same(native, python)


def test_the_probed_boom_through_the_cli_writes_the_python_paths_bytes(tmp_path):
    """``latdyn run`` of the boom with its PI's state and output recorded, as a user types it: the smooth steps in the
    loop, and the switch off (a process of its own) writes the same sensitivities.csv, probes.csv and summary.json's
    sensitivities, byte for byte."""
    completed, out = latdyn_run(tmp_path, BOOM_PROBED)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] >= summary["steps"] - 2
    the_loop_off_writes_the_same(tmp_path, out)
