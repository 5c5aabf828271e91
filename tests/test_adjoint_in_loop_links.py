"""The discrete adjoint on models with rigid links or guides in the loop of steps (latdyn/analyses/adjoint_in_loop.py;
issue 34, item 6): the forward pass's smooth steps stored by the loop of steps in C (summary.json
``sensitivity_steps_in_loop``), the reverse pass's smooth steps in one native call each on the compiled step's
reduction (csrc/adjoint_reverse.c with csrc/linked_matrices.c), and the derivatives the per-step Python and NumPy
path's (the private switches ``ADJOINT_IN_LOOP`` and ``REVERSE_NATIVE`` off) to the bit, through the API and the
CLI, and the forward method's to 1e-10 of each output's largest: the gimbal of rigid links (free, and its inner ring
latching), the slider-crank closed by a rigid rod and the guided one bouncing between its stops, the deploying chain of
rigid bays (opening, and latching in line), the 3D arm with a guided mass (free, and hitting its stop)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, latdyn_run_switched, summary_of
from tests.resumed_runs import resumed_inside_the_loop_is_whole
from tests.test_adjoint_in_loop import _run
from tests.test_sensitivities_guides import STOP_3D
from tests.test_sensitivities_in_loop_links import CHAIN, CRANK_STOPS, GIMBAL_JOINTS, GIMBAL_LATCH, GUIDED
from tests.test_sensitivities_rigid_links import CLOSED_SLIDER_CRANK


def _adjoint(text: str) -> str:
    """``text`` by the discrete adjoint."""
    out = text.replace("solve: {", "solve: {sensitivity_method: adjoint, ")
    assert out != text
    return out


#: the chain of rigid bays before its first latch (t = 0.251 s): no event
CHAIN_OPENING = CHAIN.replace("t_end: 0.5,", "t_end: 0.2,")
assert CHAIN_OPENING != CHAIN

SCENES = {"gimbal": GIMBAL_JOINTS, "gimbal, latch": GIMBAL_LATCH, "closed slider-crank": CLOSED_SLIDER_CRANK,
          "guided slider-crank, stops": CRANK_STOPS, "chain of rigid bays": CHAIN_OPENING,
          "chain of rigid bays, latches": CHAIN, "3D guided arm": GUIDED, "3D guided arm, stop": STOP_3D}


#: the floor of :func:`_largest_gap`'s scale, relative to the largest derivative of the run
ROUND_OFF_FLOOR = 1e-6


def _largest_gap(adjoint: dict, forward: dict) -> float:
    """The largest difference of ``adjoint``'s probe derivatives from ``forward``'s (summary.json
    ``probe_sensitivities``), relative to each output's largest derivative, but never to less than
    :data:`ROUND_OFF_FLOOR` times the largest derivative of any output: every output is read from the same carried
    δq, δv (or the same reverse pass), whose round-off is relative to their largest entries, not to a small output's
    own (an output whose derivatives are all round-off, ~1e-17, of an exact 0 read its round-off as a gap of order 1:
    tests/test_read_mends.py)."""
    largest = max((abs(value) for by in forward.values() for values in by.values() for value in values.values()),
                  default=0.0)
    gap = 0.0
    for probe, by in forward.items():
        for which, values in by.items():
            scale = max(max(abs(value) for value in values.values()), ROUND_OFF_FLOOR * largest) or 1.0
            gap = max(gap, max(abs(adjoint[probe][which][name] - value) for name, value in values.items()) / scale)
    return gap


@pytest.mark.parametrize("name", list(SCENES))
def test_the_linked_passes_in_the_loop_give_the_python_paths_derivatives(name, monkeypatch):
    """The loop of steps stores every smooth step (every step without events; with them all but the events' steps
    and the landings after them, from Python), the reverse pass takes at least those natively, and the derivatives
    are the Python and NumPy path's to the bit — each probe's end, max and min, each event's time, every row — and the
    forward method's to 1e-10."""
    text = _adjoint(SCENES[name])
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert native.summary["time_loop"] == "compiled" and python.summary["time_loop"] == "python"
    assert python.summary["sensitivity_steps_in_loop"] == 0 and python.native_reverse == 0
    if native.summary["event_sensitivities"]:
        assert 0 < in_loop < steps and in_loop <= native.native_reverse < steps
    else:
        assert in_loop == native.native_reverse == steps > 0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    forward = latdyn.run(latdyn.load_scene(yaml.safe_load(SCENES[name])))
    assert _largest_gap(native.summary["probe_sensitivities"], forward.summary["probe_sensitivities"]) <= 1e-10
    for mine, theirs in zip(native.summary["event_sensitivities"], forward.summary["event_sensitivities"]):
        for key, value in theirs["dt"].items():
            assert abs(mine["dt"][key] - value) <= 1e-10 * max(abs(v) for v in theirs["dt"].values()), key


def test_the_cli_writes_the_python_paths_files_on_the_guided_slider_crank(tmp_path):
    """``latdyn run`` on the guided slider-crank bouncing between its stops takes the loop; the same command with the
    switches off (in a process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and the
    same derivatives in summary.json."""
    completed, out = latdyn_run(tmp_path, _adjoint(CRANK_STOPS))
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and 0 < summary["sensitivity_steps_in_loop"] < summary["steps"]
    reference = tmp_path / "python"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", reference, "import latdyn.analyses.adjoint_in_loop "
                              "as loop; loop.ADJOINT_IN_LOOP = False; loop.REVERSE_NATIVE = False")
    assert run.returncode == 0, run.stderr
    assert summary_of(reference)["sensitivity_steps_in_loop"] == 0
    for name in ("sensitivities.csv", "probes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    for key in ("probe_sensitivities", "event_sensitivities"):
        assert summary[key] == summary_of(reference)[key], key


@pytest.mark.parametrize("name, t_stop", [("guided slider-crank, stops", 0.1), ("3D guided arm", 0.2)])
def test_a_linked_run_interrupted_inside_the_loop_resumes_to_the_same_files(name, t_stop, tmp_path, monkeypatch):
    """Interrupted (Ctrl-C) as a loop of steps starts at ``t_stop`` (the slider-crank between its stops' events, the
    arm with none) and resumed from its checkpoint: sensitivities.csv and summary.json's derivatives and count of steps
    in the loop are the uninterrupted run's, byte for byte."""
    resumed_inside_the_loop_is_whole(yaml.safe_load(_adjoint(SCENES[name])), tmp_path, monkeypatch, t_stop)
