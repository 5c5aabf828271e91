"""Result files: round trip, crash safety (exception, SIGKILL), pickling (ParaView frames: test_paraview.py)."""
from __future__ import annotations

import json
import os
import pickle
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from latdyn.results import state_history
from latdyn.results import writer as results
from latdyn.results.writer import Result, ResultWriter, load_state_history
from latdyn.errors import ResultsError

ROOT = Path(__file__).resolve().parents[1]


def _rows(n, rng):
    t = np.linspace(0.0, 1.0, n)
    values = rng.standard_normal((n, 2)) * 10.0 ** rng.integers(-8, 8, size=(n, 2))
    return t, values


def _csv_lines(path: Path) -> list[str]:
    text = path.read_text()
    assert text.endswith("\n"), "probes.csv must end with a complete line"
    return text.splitlines()


def test_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(1)
    t, values = _rows(37, rng)
    with ResultWriter(tmp_path / "out", ["tip_v", "energy"]) as writer:
        for ti, row in zip(t, values):
            writer.record(ti, row, state={"q": rng.standard_normal(5), "v": rng.standard_normal(3)})
        writer.summary["steps"] = 36
    loaded = Result.load(tmp_path / "out")
    assert loaded.first_column == "t"
    np.testing.assert_array_equal(loaded.t, t)  # repr(float) round-trips bit for bit
    np.testing.assert_array_equal(loaded.probes["tip_v"], values[:, 0])
    np.testing.assert_array_equal(loaded.probes["energy"], values[:, 1])
    assert list(loaded.probes) == ["tip_v", "energy"]
    assert loaded.summary["status"] == "solved"
    assert loaded.summary["steps"] == 36
    assert loaded.modes is None

    in_memory = writer.result()
    np.testing.assert_array_equal(in_memory.t, loaded.t)
    for name in loaded.probes:
        np.testing.assert_array_equal(in_memory.probes[name], loaded.probes[name])
    assert in_memory.summary == loaded.summary

    history = load_state_history(tmp_path / "out")
    assert history["t"].shape == (37,)
    assert history["q"].shape == (37, 5) and history["v"].shape == (37, 3)


def test_header_summary_keys_and_static_first_column(tmp_path):
    writer = ResultWriter(tmp_path, ["a", "b,c"], first_column="load_factor", meta={"title": "x"})
    writer.record(0.5, {"b,c": 2.0, "a": 1.0})
    summary = writer.close({"scene_hash": "abc", "energy_balance_error": float("nan")})
    lines = _csv_lines(tmp_path / "probes.csv")
    assert lines[0] == 'load_factor,a,"b,c"'
    assert lines[1] == "0.5,1.0,2.0"
    for key in ("latdyn_version", "scene_hash", "wall_time_s", "steps", "newton_iterations",
                "rejected_steps", "energy_balance_error", "status"):
        assert key in summary
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk == summary
    assert on_disk["energy_balance_error"] is None  # strict JSON: non-finite -> null
    assert on_disk["title"] == "x"
    loaded = Result.load(tmp_path)
    assert loaded.first_column == "load_factor"
    np.testing.assert_array_equal(loaded.load_factor, [0.5])
    assert list(loaded.probes) == ["a", "b,c"]


def test_summary_says_running_until_closed(tmp_path):
    writer = ResultWriter(tmp_path, ["x"])
    writer.record(0.0, [1.0])
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "running"
    writer.close()
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "solved"


def test_wrong_number_of_values_is_rejected_before_writing(tmp_path):
    with ResultWriter(tmp_path, ["x", "y"]) as writer:
        with pytest.raises(ValueError):
            writer.record(0.0, [1.0])
    assert _csv_lines(tmp_path / "probes.csv") == ["t,x,y"]


@pytest.mark.parametrize("exception, status", [(RuntimeError, "failed"), (KeyboardInterrupt, "interrupted")])
def test_exception_inside_with_leaves_complete_files(tmp_path, exception, status):
    rng = np.random.default_rng(2)
    with pytest.raises(exception):
        with ResultWriter(tmp_path, ["x", "y"], checkpoint_rows=4) as writer:
            for i in range(10):
                writer.record(0.1 * i, rng.standard_normal(2), state={"q": np.full(3, float(i))})
            raise exception("boom")
    lines = _csv_lines(tmp_path / "probes.csv")
    assert len(lines) == 11 and all(len(line.split(",")) == 3 for line in lines)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == status
    history = load_state_history(tmp_path)
    np.testing.assert_array_equal(history["q"][:, 0], np.arange(10.0))  # close() wrote all rows
    assert Result.load(tmp_path).t.size == 10


def test_npz_fallback_without_h5py(tmp_path, monkeypatch):
    monkeypatch.setattr(state_history, "h5py", None)
    with ResultWriter(tmp_path, ["x"], checkpoint_rows=2) as writer:
        for i in range(5):
            writer.record(float(i), [i * 2.0], state={"q": np.array([i, -i], dtype=float)})
            if i == 1:
                assert load_state_history(tmp_path)["t"].size == 2  # a checkpoint already on disk
    assert not (tmp_path / "state.h5").exists()
    history = load_state_history(tmp_path)
    np.testing.assert_array_equal(history["t"], np.arange(5.0))
    np.testing.assert_array_equal(history["q"][:, 1], -np.arange(5.0))
    assert json.loads((tmp_path / "summary.json").read_text())["state_file"] == "state.npz"


def test_state_keys_must_not_change(tmp_path):
    with ResultWriter(tmp_path, ["x"]) as writer:
        writer.record(0.0, [0.0], state={"q": np.zeros(2)})
        with pytest.raises(ValueError):
            writer.record(1.0, [0.0], state={"r": np.zeros(2)})
        with pytest.raises(ValueError):
            writer.record(1.0, [0.0], state={"q": np.zeros(3)})


def test_sigkill_after_checkpoint_leaves_readable_files(tmp_path):
    out = tmp_path / "out"
    script = textwrap.dedent(f"""
        import os, signal
        import numpy as np
        from latdyn.results.writer import ResultWriter
        writer = ResultWriter({str(out)!r}, ["x", "y"], checkpoint_rows=10**9, checkpoint_seconds=1e9)
        for i in range(50):
            writer.record(0.01 * i, [i, -i], state={{"q": np.full(4, float(i))}})
        writer.checkpoint()
        for i in range(50, 73):
            writer.record(0.01 * i, [i, -i], state={{"q": np.full(4, float(i))}})
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    completed = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True)
    assert completed.returncode == -signal.SIGKILL, completed.stderr
    lines = _csv_lines(out / "probes.csv")
    assert lines[0] == "t,x,y"
    # rows go to probes.csv in blocks (latdyn.results.probes_csv.CSV_BLOCK_ROWS): every row up to
    # the checkpoint is there, later ones up to the last block written, each complete
    assert 51 <= len(lines) <= 74
    loaded = Result.load(out)
    np.testing.assert_array_equal(loaded.probes["x"], np.arange(len(lines) - 1.0))
    history = load_state_history(out)  # opens: the checkpointed rows, nothing half-written
    np.testing.assert_array_equal(history["q"][:, 0], np.arange(50.0))
    assert json.loads((out / "summary.json").read_text())["status"] == "running"
    assert not list(out.glob("*.tmp"))


def test_modes_csv(tmp_path):
    with ResultWriter(tmp_path, []) as writer:
        writer.write_modes([0.0, 1.5, 3.25])
    assert _csv_lines(tmp_path / "modes.csv") == ["mode,frequency_hz", "1,0.0", "2,1.5", "3,3.25"]
    loaded = Result.load(tmp_path)
    np.testing.assert_array_equal(loaded.modes, [0.0, 1.5, 3.25])
    assert loaded.t.size == 0 and loaded.probes == {}


def test_result_pickles(tmp_path):
    with ResultWriter(tmp_path, ["x"]) as writer:
        writer.record(0.0, [1.0])
        writer.write_modes([2.0])
    for result in (writer.result(), Result.load(tmp_path)):
        clone = pickle.loads(pickle.dumps(result))
        np.testing.assert_array_equal(clone.t, result.t)
        np.testing.assert_array_equal(clone.probes["x"], result.probes["x"])
        np.testing.assert_array_equal(clone.modes, result.modes)
        assert clone.summary == result.summary and clone.out_dir == result.out_dir


def test_writer_without_folder_keeps_rows_in_memory():
    with ResultWriter(None, ["x"]) as writer:
        writer.record(0.0, [3.0], state={"q": np.zeros(2)}, node_positions=np.zeros((2, 3)))
    result = writer.result()
    assert result.out_dir is None and result.summary["status"] == "solved"
    np.testing.assert_array_equal(result.probes["x"], [3.0])


def test_rerun_removes_stale_files(tmp_path):
    with ResultWriter(tmp_path, ["x"]) as writer:
        writer.record(0.0, [1.0], state={"q": np.zeros(1)})
        writer.write_modes([1.0])
    ResultWriter(tmp_path, ["y"])  # a new run into the same folder, not yet closed
    assert not (tmp_path / "modes.csv").exists() and not (tmp_path / "state.h5").exists()
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "running"


def test_load_errors_name_the_path(tmp_path):
    with pytest.raises(ResultsError, match="no such results folder"):
        Result.load(tmp_path / "missing")
    with pytest.raises(ResultsError, match=str(tmp_path)):
        Result.load(tmp_path)
    (tmp_path / "probes.csv").write_text("t,x\n0.0,1.0\nnot,a,row\n1.0,2.0\n")
    with pytest.raises(ResultsError, match="line 3"):
        Result.load(tmp_path)


def test_truncated_last_line_is_ignored(tmp_path):
    (tmp_path / "probes.csv").write_text("t,x,y\n0.0,1.0,2.0\n0.1,1.")
    loaded = Result.load(tmp_path)
    np.testing.assert_array_equal(loaded.t, [0.0])


def test_progress_bar_disabled_and_enabled(capsys):
    bar = results.progress_bar(2.0, enabled=False)
    bar.update(1.0)
    bar.close()
    with results.progress_bar(2.0, enabled=True) as bar:
        for t in (0.5, 1.0, 3.0):
            bar.update(t, dt=1e-3)
    assert capsys.readouterr().out == ""


@pytest.mark.parametrize("backend", ["h5", "npz"])
def test_state_labels_are_stored(tmp_path, monkeypatch, backend):
    if backend == "npz":
        monkeypatch.setattr(state_history, "h5py", None)
    labels = results.state_labels(["hub", "arm.node[1]"], ["arm.start"])
    assert labels["x"][3:6] == ["arm.node[1]:x", "arm.node[1]:y", "arm.node[1]:z"]
    assert labels["T"][9 + 5] == "arm.node[1]:T[1,2]"
    with ResultWriter(tmp_path, [], labels=labels, attributes={"nodes": ["hub", "arm.node[1]"]}) as writer:
        writer.record(0.0, [], state={"x": np.arange(6.0), "T": np.zeros(18), "theta": np.zeros(1)})
    got = results.load_state_labels(tmp_path)
    assert got["nodes"] == ["hub", "arm.node[1]"]
    assert got["columns"] == {"x": labels["x"], "T": labels["T"], "theta": ["arm.start"]}  # no v, w: not recorded
    history = load_state_history(tmp_path)
    assert sorted(history) == ["T", "t", "theta", "x"]
    assert history["x"][0, got["columns"]["x"].index("arm.node[1]:y")] == 4.0


def test_state_labels_must_fit_the_widths(tmp_path):
    with ResultWriter(tmp_path, [], labels={"x": ["a:x", "a:y"]}) as writer:
        with pytest.raises(ValueError, match="labels"):
            writer.record(0.0, [], state={"x": np.zeros(3)})


def test_the_writer_module_still_offers_the_names_that_moved():
    """Each output has its own module now; importers of latdyn.results.writer find the same objects."""
    from latdyn.results import progress, result

    assert results.Result is result.Result
    assert results.load_state_history is result.load_state_history
    assert results.load_state_labels is result.load_state_labels
    assert results.state_labels is state_history.state_labels
    assert results.progress_bar is progress.progress_bar
    assert all(hasattr(results, name) for name in results.__all__)


# ----------------------------------------------------------------------------- frames and labels of a run
RUN_SCENE = {
    "title": "result files",
    "sections": {"s": {"EA": 1.0e5, "EIy": 20.0, "EIz": 20.0, "GJ": 15.0, "rhoA": 0.5,
                       "rhoIy": 1.0e-4, "rhoIz": 1.0e-4}},
    "bodies": {
        "hub": {"at": [0, 0, 0], "motion": {"rotation": {"axis": [0, 0, 1], "angle": "20*t**2"}}},
        "tip": {"at": [1.1, 0, 0], "mass": 0.5, "inertia": [1e-3, 1e-3, 1e-3]},
    },
    "beams": {"arm": {"from": {"body": "hub", "offset": [0.1, 0, 0]}, "to": "tip", "section": "s",
                      "elements": 4, "start": {"hinge": {"axis": [0, 0, 1], "stiffness": 200.0}}}},
    # 201 steps: 202 candidate frames, more than the 200 kept, so the last one is skipped by the stride
    "solve": {"analysis": "transient", "t_end": 0.201, "dt": 0.001},
    "output": {"probes": {
        "n0": {"element": "arm.element[0]", "quantity": "axial_force"},
        "n3": {"element": "arm.element[3]", "quantity": "axial_force"},
        "m3": {"element": "arm.element[3]", "quantity": "moment_z"},
        "tip_vy": {"point": "arm.end", "quantity": "velocity", "frame": "global", "component": "y"},
        "start_dx": {"point": "arm.start", "quantity": "displacement", "frame": "global", "component": "x"},
        "start_vx": {"point": "arm.start", "quantity": "velocity", "frame": "global", "component": "x"},
    }},
}


@pytest.fixture(scope="module")
def run_out(tmp_path_factory):
    pytest.importorskip("h5py")
    import latdyn

    out = tmp_path_factory.mktemp("run") / "out"
    result = latdyn.run(RUN_SCENE, out_dir=out)
    return out, Result.load(out), result


def test_run_state_history_is_labelled(run_out):
    from latdyn.assembly.prepare import prepare

    out, loaded, _ = run_out
    model = prepare(RUN_SCENE).model
    names = [n.name for n in model.nodes]
    labels = results.load_state_labels(out)
    assert labels["nodes"] == names and "arm.node[3]" in names
    assert labels["hinges"] == ["arm.start"]
    assert labels["coordinates"] == model.dof_names()
    columns = labels["columns"]
    assert columns["x"] == [f"{n}:{c}" for n in names for c in "xyz"]
    assert columns["v"] == columns["w"] == columns["x"]
    assert columns["T"] == [f"{n}:T[{i},{j}]" for n in names for i in range(3) for j in range(3)]
    assert columns["theta"] == columns["theta_dot"] == ["arm.start"]
    history = load_state_history(out)
    np.testing.assert_array_equal(history["t"], loaded.t)
    x0 = history["x"][0]
    assert x0[columns["x"].index("arm.node[3]:x")] == pytest.approx(0.1 + 0.75)
    assert x0[columns["x"].index("tip:x")] == 1.1
    # the hub turns about z by 20 t²: its T[0,1] is -sin(20 t²)
    t_end = loaded.t[-1]
    assert history["T"][-1, columns["T"].index("hub:T[0,1]")] == pytest.approx(-np.sin(20 * t_end ** 2), rel=1e-12)
    import h5py

    with h5py.File(out / "state.h5", "r") as f:
        assert "node" in f["x"].attrs["description"]
