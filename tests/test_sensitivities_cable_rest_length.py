"""A cable's rest length and ρA by the sensitivities, against differences of whole runs that are a derivative
(issue 34; docs/parameters.md "Cables", its "Step sizes").

The skew cable catching the tip of a 3D arm whose root hinge's torque a clipped controller sets from the hinge's
angle and the cable's tension (taut, slack, taut, slack, taut in 0.25 s), the cable damped and of mass. Perturbed
by 1e-4 of the rest length, the changes move by about 3e-4 s; after a damped cable goes taut the steps restart at
0.01 dt and double until a grid point (``latdyn.timeloop.events.TAUT_JUMP_STEP``), so that move changes how many
steps fit before the grid point, and the run itself jumps (a different sequence of steps): such differences are no
derivative (the 4.3e-2 of issue 34's loopstates report on this scene without the cable's mass). Perturbed by 1e-6,
every run keeps the base run's steps and the differences agree with the sensitivities. The Newton tolerance is
tightened to 1e-12 so that no perturbed run takes a different number of Newton iterations in a step (with the
default 1e-8 the runs at ±1e-6 took 218 and 217 iterations, and the differences moved by 3e-6 of the largest)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.results.result import Result
from tests.cli_runs import latdyn_run, summary_of
from tests.test_sensitivities_in_loop_controller_reads import CABLE_LIMIT

#: tests/test_sensitivities_in_loop_controller_reads.py's CABLE_LIMIT (tests/test_sensitivities_cables.py's CABLE_3D
#: on a root hinge whose torque a clipped controller sets from its angle and the cable's tension), the cable of mass
#: ρA = rA, the Newton tolerance 1e-12, by the rest length and ρA
CABLE_REST = (CABLE_LIMIT.replace("parameters: {Kp:", "parameters: {rA: 0.05, Kp:")
              .replace('damping: "c"}', 'damping: "c", rhoA: "rA"}')
              .replace("solve: {analysis: transient,", "solve: {tol: 1.0e-12, analysis: transient,")
              .replace("sensitivities: [Kp, Kt, EI, m]", "sensitivities: [L, rA]"))
assert all(mark in CABLE_REST for mark in ('rhoA: "rA"', "rA: 0.05", "tol: 1.0e-12", "[L, rA]"))
CHANGES = ["taut", "slack", "taut", "slack", "taut"]


def _run(only: str | None = None, **values) -> latdyn.Result:
    data = yaml.safe_load(CABLE_REST)
    data["parameters"].update(values)
    if only is not None:   # (a run with sensitivities lands on the changes as the differentiated run does)
        data["solve"]["sensitivities"] = [only]
    return latdyn.run(latdyn.load_scene(data))


def _richardson(name: str, relative: float) -> tuple[dict, list[int]]:
    """Richardson-extrapolated central differences of whole runs by ``name`` (steps ``relative`` and half of it of
    its value), each probe; and the perturbed runs' numbers of steps."""
    p0 = yaml.safe_load(CABLE_REST)["parameters"][name]
    central, steps = [], []
    for step in (relative * p0, 0.5 * relative * p0):
        up, down = _run(name, **{name: p0 + step}), _run(name, **{name: p0 - step})
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]] == CHANGES
        steps += [up.summary["steps"], down.summary["steps"]]
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}, steps


def _worst(result, expected: dict, name: str) -> float:
    """The largest error of ``result``'s sensitivities by ``name``, each probe over the rows relative to its
    largest difference."""
    return max(np.abs(result.sensitivities[(probe, name)] - value).max() / np.abs(value).max()
               for probe, value in expected.items())


@pytest.fixture(scope="module")
def result():
    run = _run()
    assert [e["kind"] for e in run.summary["events"]] == CHANGES and run.summary["status"] == "solved"
    return run


@pytest.mark.parametrize("name, relative, tolerance", [("L", 1e-6, 1e-7), ("rA", 1e-4, 1e-6)])
def test_the_rest_length_and_mass_agree_with_differences_that_keep_the_steps(result, name, relative, tolerance):
    """By the rest length (perturbed by 1e-6) and by ρA (1e-4: ρA moves no change of the cable), every probe over
    the rows within ``tolerance`` of its largest difference (measured: L 4.8e-10, rA 7.2e-9; rA at 1e-6 is
    round-off, 2.1e-6); every perturbed run keeps the base run's 66 steps."""
    expected, steps = _richardson(name, relative)
    assert steps == [result.summary["steps"]] * 4
    assert _worst(result, expected, name) <= tolerance


def test_differences_of_1e_4_of_the_rest_length_change_the_steps_and_are_no_derivative(result):
    """The perturbed runs of 1e-4 (and 5e-5) of L take 62, 68, 65, 67 steps against the base run's 66 (measured):
    the changes moved across the doubling steps after a taut change; their differences are 1.7e-2 off (measured),
    which is the run's jump, not the sensitivities' error (the test above)."""
    expected, steps = _richardson("L", 1e-4)
    assert any(count != result.summary["steps"] for count in steps)
    assert _worst(result, expected, "L") > 1e-3


def test_the_cli_writes_the_apis_sensitivities_by_the_rest_length(tmp_path, result):
    """``python -m latdyn run``: solved, the same changes, and sensitivities.csv read back equal to the API's."""
    completed, out = latdyn_run(tmp_path, CABLE_REST)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["status"] == "solved" and [e["kind"] for e in summary["events"]] == CHANGES
    assert summary["event_sensitivities"] == result.summary["event_sensitivities"]
    read = Result.load(out)
    for key, values in result.sensitivities.items():
        np.testing.assert_array_equal(values, read.sensitivities[key])


def test_the_loop_of_steps_gives_the_per_step_paths_bits(result, monkeypatch):
    """The smooth steps in the loop of steps (45 of 66, measured; the changes and the steps near them from Python),
    the same sensitivities and event times' derivatives, to the bit, with the loop switched off."""
    monkeypatch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", False)
    python = _run()
    assert 40 <= result.summary["sensitivity_steps_in_loop"] < result.summary["steps"]
    assert python.summary["sensitivity_steps_in_loop"] == 0
    assert python.summary["event_sensitivities"] == result.summary["event_sensitivities"]
    for key, values in result.sensitivities.items():
        np.testing.assert_array_equal(values, python.sensitivities[key])
