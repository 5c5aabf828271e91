"""Sparse step matrices in the transient sensitivities' loop of steps (issue 34 item 2; latdyn/analyses/
sensitivities_in_loop.py, csrc/sensitivity_step.c): a numbering whose step matrix S takes the supernodal sparse LU
(above DENSE_LIMIT coordinates, its bandwidth after reverse Cuthill–McKee above BAND_LIMIT) takes its smooth steps'
sensitivities in the loop of steps, one sparse factorization of S and k + 1 back-substitutions a step, as the per-step
Python path does with the same native call: equal to the bit through the API and the CLI on a 3D space frame of 512
members (846 coordinates), also where every sparse pivot fails and the band LU with pivoting stands in on both paths
(``latdyn_sensitivity_step_pivoted``: Factorization._factor_pivoted's band, the same storage and order). The discrete
adjoint's reverse pass takes those steps in its native call too (csrc/adjoint_reverse.c), equal to the NumPy path's.
Rigid links and guides above DENSE_LIMIT coordinates or on a sparse storage: M, C and K of the compiled step's
reduction on the iteration matrix's reduced pattern (csrc/linked_matrices.c ``latdyn_linked_exact_values``), S on it,
on both paths — a 3D deploying chain of rigid bays latching twice, its flexible boom of 24 elements (band), and the
space frame with a line of rigid top chords (sparse)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from benchmarks.sparse_sensitivities_loop import space_frame
from latdyn.analyses import step_matrix
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_in_loop_links import CHAIN


def _text(method: str | None = None) -> str:
    """The 9 × 9 double-layer space frame (benchmarks/sparse_sensitivities_loop.py), 12 steps, differentiated by
    three members' EA, the centre load's amplitude P and a bottom joint's mass m, as YAML a user types."""
    data = space_frame(["F0", "F40", "F300", "P", "m"], 9, t_end=0.012, method=method)
    data["parameters"].update({"P": 1.0, "m": 0.2})
    data["loads"][0]["force"] = [0, "3000*P*t", "-20000*P*t"]
    data["bodies"]["b4_4"]["mass"] = "m"
    return yaml.safe_dump(data, sort_keys=False)


def _run(text: str, monkeypatch, in_loop: bool, pivots_fail: bool = False, reverse: list | None = None):
    """The scene through the API, its smooth steps' sensitivities in the loop of steps or from Python; the kinds of
    the step matrices' factorizations made on the way; ``pivots_fail``: every pivot of S's sparse LU fails (its
    tolerance above any pivot's ratio to its scale), so that the band LU with pivoting stands in at every step;
    ``reverse``: collects whether each reverse step of the adjoint was taken natively (its switches with the loop's)."""
    from latdyn.analyses.adjoint_in_loop import ReverseSteps

    made, original, native_step = [], step_matrix.ExactStepMatrix.__init__, ReverseSteps.step

    def recording(self, *args, **kwargs):
        original(self, *args, **kwargs)
        made.append(self.factorization.kind)
        if pivots_fail and self.factorization.kind == "sparse":
            self.factorization.structure.sparse_lu.contents.pivot_tolerance = 2.0

    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        patch.setattr(step_matrix.ExactStepMatrix, "__init__", recording)
        patch.setattr("latdyn.analyses.adjoint_in_loop.ADJOINT_IN_LOOP", in_loop)
        patch.setattr("latdyn.analyses.adjoint_in_loop.REVERSE_NATIVE", in_loop)
        if reverse is not None:
            patch.setattr(ReverseSteps, "step", lambda self, *a: reverse.append((w := native_step(self, *a)) is not None)
                          or w)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text))), made


@pytest.mark.parametrize("pivots_fail", [False, True], ids=["sparse LU", "every sparse pivot failing"])
def test_the_sparse_steps_in_the_loop_are_the_python_paths(pivots_fail, monkeypatch):
    """Every step of the space frame (S on the sparse LU) is differentiated in the loop of steps and the sensitivities
    are the per-step Python path's to the bit; with every sparse pivot failing, the band LU with pivoting stands in
    on both paths (the Python path's Factorization._factor_pivoted at every step), to the bit too."""
    from latdyn.assembly.factorization import Factorization

    text = _text()
    native, kinds = _run(text, monkeypatch, True, pivots_fail)
    pivoted, original = [], Factorization._factor_pivoted
    monkeypatch.setattr(Factorization, "_factor_pivoted", lambda self, *a: pivoted.append(1) or original(self, *a))
    python, _ = _run(text, monkeypatch, False, pivots_fail)
    assert kinds == ["sparse"]   # S on the sparse LU (one numbering)
    steps = native.summary["steps"]
    assert native.summary["sensitivity_steps_in_loop"] == steps == 12 and python.summary["sensitivity_steps_in_loop"] == 0
    assert len(pivoted) == (steps if pivots_fail else 0)
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert all(np.abs(python.sensitivities[("sag", name)]).max() > 0.0 for name in ("F0", "P", "m"))
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]


@pytest.mark.parametrize("pivots_fail", [False, True], ids=["sparse LU", "every sparse pivot failing"])
def test_the_adjoints_sparse_reverse_steps_are_the_numpy_paths(pivots_fail, monkeypatch):
    """The adjoint on the space frame: its forward pass stored by the loop of steps and every reverse step in one
    native call (S⁻ᵀ by the sparse LU's factors, or the band LU's where every sparse pivot fails), the probes'
    derivatives those of the Python and NumPy path to the bit."""
    text, taken = _text("adjoint"), []
    native, _ = _run(text, monkeypatch, True, pivots_fail, taken)
    python, _ = _run(text, monkeypatch, False, pivots_fail)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] == 12 == len(taken) and all(taken)
    assert python.summary["sensitivity_steps_in_loop"] == 0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["probe_sensitivities"]["sag"]["end"]["P"] != 0.0


def test_the_cli_writes_the_sparse_space_frames_python_path_files(tmp_path):
    """``latdyn run`` on the space frame takes the loop for every step; the same command with the switch off (in a
    process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's
    sensitivities."""
    completed, out = latdyn_run(tmp_path, _text(), quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] == summary["steps"] == 12
    the_loop_off_writes_the_same(tmp_path, out)


#: the deploying chain of rigid bays of tests/test_sensitivities_in_loop_links.py with a boom of 24 elements (above
#: DENSE_LIMIT on the minimum coordinates), through its first latch
LONG_CHAIN = CHAIN.replace("section: boom, elements: 3}", "section: boom, elements: 24}").replace(
    "t_end: 0.5", "t_end: 0.3")


def _rigid_chords() -> str:
    """The space frame with four top chords in a line across its middle rigid, their ρA the parameter rho."""
    data = yaml.safe_load(_text())
    data["parameters"]["rho"] = 0.645
    data["solve"]["sensitivities"] = ["F0", "F300", "P", "rho"]
    for i in range(4):
        data["beams"][f"tx{i}_4"]["rigid"] = True
        data["sections"][f"tx{i}_4"]["rhoA"] = "rho"
    return yaml.safe_dump(data, sort_keys=False)


@pytest.mark.parametrize("text, kind, events", [(LONG_CHAIN, "band", 1), (_rigid_chords, "sparse", 0)],
                         ids=["3D rigid chain latching, a boom of 24 elements", "space frame with rigid chords"])
def test_large_linked_steps_in_the_loop_are_the_python_paths(text, kind, events, monkeypatch):
    """A model with rigid links above DENSE_LIMIT coordinates: every smooth step in the loop of steps (the latch's
    step and the landing after it from Python), S on the reduced pattern, the sensitivities the per-step path's to
    the bit (that path's, in turn, ca1051c's to the bit on both scenes: measured). The space frame's text is made
    here, not at collection (0.5 s of YAML, which every worker collecting the suite paid)."""
    text = text() if callable(text) else text
    native, kinds = _run(text, monkeypatch, True)
    python, _ = _run(text, monkeypatch, False)
    from latdyn.numerics.linalg import DENSE_LIMIT

    assert set(kinds) == {kind} and native.summary["coordinates"] > DENSE_LIMIT
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert len(native.summary["events"]) == events and python.summary["sensitivity_steps_in_loop"] == 0
    assert (in_loop == steps) if events == 0 else (steps - 3 * events <= in_loop < steps)
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
