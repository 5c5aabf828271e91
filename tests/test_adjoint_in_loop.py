"""The discrete adjoint's forward pass in the loop of steps in C and its reverse pass's smooth steps in one native
call each (latdyn/analyses/adjoint_in_loop.py, csrc/adjoint_trajectory.c, csrc/adjoint_reverse.c; issue 34 item 6):
the loop stores each accepted step for the reverse pass (summary.json ``sensitivity_steps_in_loop`` counts them)
and the reverse pass takes the smooth steps natively, whatever the parameters' kinds, and the derivatives are the
per-step Python and NumPy path's (the private switches ``ADJOINT_IN_LOOP`` and ``REVERSE_NATIVE`` off) to the bit
through the API and the CLI, with the events' steps taken from Python between the loop's; a model the forward
method's loop refuses (a cable) keeps the whole run on the Python path; a run interrupted inside the loop resumes to
the same files."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, latdyn_run_switched, summary_of
from tests.resumed_runs import resumed_inside_the_loop_is_whole
from tests.test_adjoint_events import DROP_PROBES, LATCH_3D_PROBES, STOP_PLANAR, _adjoint
from tests.test_sensitivities_in_loop import ARM_3D

#: the 3D spinning arm of tests/test_sensitivities_in_loop.py by the adjoint (no event: every step in the loop)
ARM_3D_ADJOINT = ARM_3D.replace("solve: {", "solve: {sensitivity_method: adjoint, ")
assert ARM_3D_ADJOINT != ARM_3D


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its forward pass's smooth steps stored by the loop of steps and its reverse
    pass's taken natively, or both from Python and NumPy; ``result.native_reverse``: the reverse steps taken natively."""
    from latdyn.analyses.adjoint_in_loop import ReverseSteps

    taken = []
    original = ReverseSteps.step

    def step(self, *args):
        w = original(self, *args)
        taken.append(w is not None)
        return w

    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.adjoint_in_loop.ADJOINT_IN_LOOP", in_loop)
        patch.setattr("latdyn.analyses.adjoint_in_loop.REVERSE_NATIVE", in_loop)
        patch.setattr(ReverseSteps, "step", step)
        result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    result.native_reverse = sum(taken)
    return result


@pytest.mark.parametrize("text", [_adjoint(STOP_PLANAR), _adjoint(LATCH_3D_PROBES), ARM_3D_ADJOINT],
                         ids=["planar stop, hinge and body parameters", "3D latch", "3D arm"])
def test_the_native_passes_give_the_python_paths_derivatives(text, monkeypatch):
    """The loop of steps stores every smooth step (all of the arm's; the stop's and the latch's runs but for the
    event's step and the landing after it, from Python), the reverse pass takes every step natively but the events'
    and those whose size moves with the parameters, and the adjoint's derivatives are the Python and NumPy path's to
    the bit: each probe's end, max and min, and each event's time."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps = native.summary["steps"]
    assert native.summary["time_loop"] == "compiled" and python.summary["time_loop"] == "python"
    assert python.summary["sensitivity_steps_in_loop"] == 0 and python.native_reverse == 0
    in_loop = native.summary["sensitivity_steps_in_loop"]
    if native.summary["event_sensitivities"]:
        assert 0 < in_loop < steps and in_loop <= native.native_reverse < steps
    else:
        assert in_loop == native.native_reverse == steps > 0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
    assert any(value != 0.0 for by in native.summary["probe_sensitivities"].values() for which in by.values()
               for value in which.values())
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))


def test_the_cli_writes_the_python_paths_files(tmp_path):
    """``latdyn run`` on the planar stop takes the loop; the same command with the switches off (in a process of its
    own) writes the same sensitivities.csv and probes.csv, byte for byte, and the same derivatives in summary.json."""
    completed, out = latdyn_run(tmp_path, _adjoint(STOP_PLANAR))
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] > 40
    reference = tmp_path / "python"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", reference, "import latdyn.analyses.adjoint_in_loop as loop; loop.ADJOINT_IN_LOOP = False; loop.REVERSE_NATIVE = False")
    assert run.returncode == 0, run.stderr
    assert summary_of(reference)["sensitivity_steps_in_loop"] == 0
    for name in ("sensitivities.csv", "probes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    for key in ("probe_sensitivities", "event_sensitivities"):
        assert summary[key] == summary_of(reference)[key], key


def test_a_cable_keeps_the_run_on_the_python_path(monkeypatch):
    """A cable (its slack and taut sides' changes) is what the adjoint's loop refuses whatever the parameters (the
    forward method's loop takes cables: tests/test_sensitivities_in_loop_cables.py): every step of the adjoint's
    forward pass from Python and of its reverse pass from NumPy, decided at the start."""
    result = _run(_adjoint(DROP_PROBES), monkeypatch, True)
    assert result.summary["time_loop"] == "python" and result.summary["sensitivity_steps_in_loop"] == 0
    assert result.native_reverse == 0
    assert result.summary["event_sensitivities"]


def test_a_run_interrupted_inside_the_loop_resumes_to_the_same_files(tmp_path, monkeypatch):
    """Interrupted (Ctrl-C) as a loop of steps starts at t ≥ 0.2, before the stop, and resumed from its checkpoint:
    sensitivities.csv and summary.json's derivatives are the uninterrupted run's, byte for byte."""
    resumed_inside_the_loop_is_whole(yaml.safe_load(_adjoint(STOP_PLANAR)), tmp_path, monkeypatch, 0.2)
