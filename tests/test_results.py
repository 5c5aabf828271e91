"""Result files: round trip, crash safety (exception, SIGKILL), ParaView frames, pickling."""
from __future__ import annotations

import json
import os
import pickle
import signal
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from latdyn import results
from latdyn.results import Result, ResultWriter, ResultsError, load_state_history

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
    monkeypatch.setattr(results, "h5py", None)
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
        from latdyn.results import ResultWriter
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
    assert len(lines) == 74  # every row recorded before the kill is there, complete
    loaded = Result.load(out)
    np.testing.assert_array_equal(loaded.probes["x"], np.arange(73.0))
    history = load_state_history(out)  # opens: the checkpointed rows, nothing half-written
    np.testing.assert_array_equal(history["q"][:, 0], np.arange(50.0))
    assert json.loads((out / "summary.json").read_text())["status"] == "running"
    assert not list(out.glob("*.tmp"))


def test_paraview_frames_are_readable(tmp_path):
    meshio = pytest.importorskip("meshio")
    lines = np.array([[0, 1], [1, 2], [2, 3]])
    x0 = np.column_stack([np.arange(4.0), np.zeros(4), np.zeros(4)])
    with ResultWriter(tmp_path, ["x"], mesh={"lines": lines, "n_nodes": 4}) as writer:
        for i in range(3):
            u = np.zeros((4, 3))
            u[:, 1] = 0.1 * i * np.arange(4.0)
            writer.record(0.5 * i, [i], node_positions=x0 + u,
                          node_data={"displacement": u, "axial_force": np.full(4, float(i))})
    pvd = ET.parse(tmp_path / "paraview" / "beams.pvd").getroot()
    datasets = pvd.findall("./Collection/DataSet")
    assert [float(d.get("timestep")) for d in datasets] == [0.0, 0.5, 1.0]
    last = meshio.read(tmp_path / "paraview" / datasets[-1].get("file"))
    np.testing.assert_allclose(last.points[:, 1], 0.2 * np.arange(4.0))
    np.testing.assert_array_equal(last.cells_dict["line"], lines)
    np.testing.assert_allclose(last.point_data["axial_force"], 2.0)
    assert last.point_data["displacement"].shape == (4, 3)


def test_paraview_frames_are_subsampled_evenly(tmp_path):
    pytest.importorskip("meshio")
    mesh = {"lines": np.array([[0, 1]]), "n_nodes": 2}
    with ResultWriter(tmp_path, ["x"], mesh=mesh, max_frames=4) as writer:
        for i in range(11):
            writer.record(float(i), [i], node_positions=np.array([[0.0, 0, 0], [1.0, i, 0]]))
    files = sorted(p.name for p in (tmp_path / "paraview").glob("*.vtu"))
    assert files == ["frame_00000.vtu", "frame_00004.vtu", "frame_00008.vtu"]
    datasets = ET.parse(tmp_path / "paraview" / "beams.pvd").getroot().findall("./Collection/DataSet")
    assert [d.get("file") for d in datasets] == files


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
