"""The rows of a run whose sensitivities are carried in the loop of steps, recorded on the loop's way
(latdyn/timeloop/loop.py ``SENSITIVITY_ROWS_IN_LOOP``; csrc/sensitivity_loop.c ``sensitivity_loop_row``): the loop
no longer returns to Python at each row; the carried δq, δv, δv̇ and δt at each row come back with the block of rows
and each row's sensitivities are :meth:`TransientSensitivities.record`'s at the row's state
(:meth:`SensitivityLoop.record_rows`; the adjoint's rows, the stored state each is: :meth:`AdjointLoop.record_rows`).
Equal to the rows taken one by one from Python (the switch off), to the bit, through the API (a 3D arm with hinge
and body parameters, the planar latch, the 3D wheel in and out of its stop) and the CLI (the deploying boom's design
run, forward and adjoint)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run_switched, summary_of
from tests.test_sensitivities_contact import WHEEL
from tests.test_sensitivities_joint_forces import BOOM
from tests.test_sensitivities_in_loop import ARM_3D_JOINTS, BOOM_DESIGN, _latch

_SWITCH = "latdyn.timeloop.loop.SENSITIVITY_ROWS_IN_LOOP"

#: the 3D arm with hinge and body parameters, its second beam hung off the knee body by an offset, probed there in
#: x and y (δx + δπ × T r with T r ≠ 0, turning in 3D)
ARM_OFFSET = (ARM_3D_JOINTS.replace("    from: knee\n", "    from: {body: knee, offset: [0.05, 0.02, 0.03]}\n")
              .replace("  probes:\n", "  probes:\n    start_x: {point: b.start, quantity: displacement, component: x}\n"
                                      "    start_y: {point: b.start, quantity: position, component: y}\n"))
assert ARM_OFFSET.count("b.start") == 3 and "offset: [0.05" in ARM_OFFSET

#: Run before a CLI's main: counts the rows recorded in the loop and writes the count to the file formatted in.
_COUNTING = """
import atexit
from latdyn.analyses.adjoint_in_loop import AdjointLoop
from latdyn.analyses.sensitivities_in_loop import SensitivityLoop
counted = [0]
for kind in (SensitivityLoop, AdjointLoop):
    def record_rows(self, carried, block, rows, original=kind.record_rows):
        counted[0] += rows
        return original(self, carried, block, rows)
    kind.record_rows = record_rows
atexit.register(lambda: open({!r}, "w").write(str(counted[0])))
"""


def _run(text: str, monkeypatch, rows_in_loop: bool) -> tuple:
    """The scene's run through the API, its rows recorded in the loop or one by one; the rows recorded in the loop."""
    from latdyn.analyses.adjoint_in_loop import AdjointLoop
    from latdyn.analyses.sensitivities_in_loop import SensitivityLoop

    counted = []
    with monkeypatch.context() as patch:
        patch.setattr(_SWITCH, rows_in_loop)
        for kind in (SensitivityLoop, AdjointLoop):
            original = kind.record_rows

            def record_rows(self, carried, block, rows, original=original):
                counted.append(rows)
                return original(self, carried, block, rows)

            patch.setattr(kind, "record_rows", record_rows)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text))), sum(counted)


@pytest.mark.parametrize("text", [ARM_OFFSET, _latch(), WHEEL, BOOM],
                         ids=["3D arm, offset", "planar latch", "3D compliant stop", "boom, latch torque"])
def test_the_rows_recorded_in_the_loop_are_the_rows_one_by_one(text, monkeypatch):
    """Most rows recorded in the loop (the last of each loop call, and those at events, from Python), and the
    sensitivities, their extremes and the events' time derivatives those of the rows one by one, to the bit: points'
    components and hinge angles all rows of a block at once (latdyn/analyses/sensitivity_rows.py), the boom's latch
    torque row by row at the rows' states."""
    (native, in_loop), (python, one_by_one) = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    rows = len(native.t)
    assert one_by_one == 0 and 0.5 * rows < in_loop < rows
    assert native.summary["sensitivity_steps_in_loop"] == python.summary["sensitivity_steps_in_loop"] > 0
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        assert len(values) == rows and np.abs(values).max() > 0.0, key
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    for key in ("probe_sensitivities", "event_sensitivities"):
        assert native.summary[key] == python.summary[key], key
    for name, values in python.probes.items():
        np.testing.assert_array_equal(native.probes[name], values, err_msg=name)


@pytest.mark.parametrize("method", ["forward", "adjoint"])
def test_the_boom_design_runs_files_are_the_rows_one_by_one(method, tmp_path):
    """``latdyn run`` of the deploying boom's design run (examples/deploying_boom_sensitivities.py), forward and by
    the adjoint, writes the sensitivities.csv, probes.csv and summary.json sensitivities of the same command with
    the rows one by one (the switch off, in a process of its own), byte for byte."""
    text = BOOM_DESIGN if method == "forward" else BOOM_DESIGN.replace(
        "sensitivities: [k, c]}", "sensitivities: [k, c], sensitivity_method: adjoint}")
    assert method == "forward" or "adjoint" in text
    (tmp_path / "scene.yaml").write_text(text)
    out, counted = tmp_path / "out", tmp_path / "rows_in_loop.txt"
    completed = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", out, f"exec({_COUNTING.format(str(counted))!r})")
    assert completed.returncode == 0, completed.stderr
    assert int(counted.read_text()) > 200   # of the 251 rows, the latch's and those ending a loop call from Python
    reference = tmp_path / "one_by_one"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", reference,
                              "import latdyn.timeloop.loop as loop; loop.SENSITIVITY_ROWS_IN_LOOP = False")
    assert run.returncode == 0, run.stderr
    summary, expected = summary_of(out), summary_of(reference)
    assert summary["sensitivity_steps_in_loop"] == expected["sensitivity_steps_in_loop"] > 400
    for name in ("sensitivities.csv", "probes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    for key in ("probe_sensitivities", "event_sensitivities", "events"):
        assert summary[key] == expected[key], key
