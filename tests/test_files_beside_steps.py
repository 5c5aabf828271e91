"""h5py, which writes ``state.h5`` and the ParaView files, imported beside a run's first steps in C rather than
with the package (docs/performance.md, "Ninth pass"): a fresh ``latdyn run`` imports it in a thread of its
own once the steps have begun, the ParaView files are created at their first write rather than at the first
frame, and the files are those of a run that imports h5py in its own thread."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

ROOT = Path(__file__).resolve().parents[1]

#: A 3D frame of two beams on a clamped corner, pushed at its tip: the compiled loop, rows every step.
SCENE = """\
title: a clamped corner of two beams, pushed
sections:
  tube: {EA: 2.0e7, EIy: 1.0e4, EIz: 1.0e4, GJ: 8.0e3, rhoA: 1.5}
bodies:
  root: {at: [0, 0, 0], fixed: true}
  corner: {at: [1, 0, 0]}
beams:
  a: {from: root, to: corner, section: tube, elements: 3}
  b: {from: corner, to: [1, 1, 0.5], section: tube, elements: 3}
loads:
  - {at: b.end, force: [0, 0, 200]}
solve: {analysis: transient, t_end: 0.05, dt: 0.001}
output:
  probes:
    tip: {point: b.end, quantity: displacement, frame: global, component: z}
"""

#: In a fresh interpreter: ``latdyn run`` as the command runs it, recording where h5py is first looked for
#: (its thread, and whether the steps in C had begun) and whether the import beside the steps is left out.
_CHILD = """
    import json, sys, threading
    import latdyn.results.writer as writer
    import latdyn.timeloop.loop as loop

    seen, began = {}, []
    if sys.argv[1] == "without":  # h5py imported where it is first used, in the run's own thread
        writer.import_h5py_beside = lambda: None

    class Watch:
        def find_spec(self, name, path=None, target=None):
            if name == "h5py" and "thread" not in seen and began:
                seen.update(thread=threading.current_thread().name, after_the_steps_began=bool(began))
            return None

    steps = loop.TimeLoop._compiled_steps

    def watched(self, *args, **kwargs):  # the loop's call of its steps in C, from the first
        began.append("h5py" in sys.modules)
        return steps(self, *args, **kwargs)

    loop.TimeLoop._compiled_steps = watched
    sys.meta_path.insert(0, Watch())
    from latdyn.cli import main

    code = main(["run", *sys.argv[2:]])
    print(json.dumps({"code": code, "h5py_before_the_steps": began[0], **seen}))
"""


def _run(tmp_path: Path, how: str, out: str) -> dict:
    scene = tmp_path / "corner.yaml"
    scene.write_text(SCENE)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(_CHILD), how, str(scene), "-o", str(tmp_path / out),
                           "-q"], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _datasets(path: Path) -> dict:
    """Every dataset and attribute of an HDF5 file, by path."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            out.update({f"{name}@{k}": np.asarray(v) for k, v in obj.attrs.items()})
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()]
        f.visititems(visit)
        out.update({f"@{k}": np.asarray(v) for k, v in f.attrs.items()})
    return out


def test_a_fresh_run_imports_h5py_beside_its_steps_and_writes_the_same_files(tmp_path):
    beside = _run(tmp_path, "beside", "beside")
    assert beside == {"code": 0, "h5py_before_the_steps": False, "thread": "latdyn-import-h5py",
                      "after_the_steps_began": True}
    alone = _run(tmp_path, "without", "alone")
    assert alone == {"code": 0, "h5py_before_the_steps": False, "thread": "MainThread", "after_the_steps_began": True}
    a, b = tmp_path / "beside", tmp_path / "alone"
    files = sorted(p.relative_to(a).as_posix() for p in a.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(b).as_posix() for p in b.rglob("*") if p.is_file())
    assert {"probes.csv", "state.h5", "summary.json", "paraview/beams.vtkhdf"} <= set(files)
    assert (a / "probes.csv").read_bytes() == (b / "probes.csv").read_bytes()
    for name in [f for f in files if f.endswith((".h5", ".vtkhdf"))]:
        x, y = _datasets(a / name), _datasets(b / name)
        assert sorted(x) == sorted(y), name
        for key in x:  # bit for bit
            assert x[key].dtype == y[key].dtype and x[key].shape == y[key].shape, (name, key)
            if x[key].dtype.kind == "O":  # strings: by value
                assert x[key].tolist() == y[key].tolist(), (name, key)
            else:
                assert x[key].tobytes() == y[key].tobytes(), (name, key)
    with h5py.File(a / "paraview" / "beams.vtkhdf", "r") as f:
        assert int(f["VTKHDF/Steps"].attrs["NSteps"]) == json.loads((a / "summary.json").read_text())["paraview_frames"]


def _frame(u: float, names=("u",)) -> dict:
    return {"beams": {"points": np.eye(3)[:2], "point_data": {n: np.full(2, u) for n in names}, "cell_data": {}}}


def test_a_paraview_file_is_created_at_its_first_write_not_at_its_first_frame(tmp_path):
    from latdyn.results import paraview

    mesh = {"beams": {"n_points": 2, "cells": [("line", np.array([[0, 1]]))], "cell_data": {}}}
    writer = paraview.ParaviewWriter(tmp_path, mesh, every=None)
    writer.record(0.0, _frame(1.0))
    writer.record(0.1, _frame(2.0))
    assert not (tmp_path / "beams.vtkhdf").exists() and not (tmp_path / "beams.vtkhdf.tmp").exists()
    assert writer.files == ["paraview/beams.vtkhdf"] and writer.bookmark()["files"] == ["beams"]
    with pytest.raises(ValueError, match="a frame with arrays"):  # checked against the first frame, as before
        writer.record(0.2, _frame(3.0, names=("v",)))
    writer.write_pending()
    with h5py.File(tmp_path / "beams.vtkhdf", "r", locking=False) as f:
        assert int(f["VTKHDF/Steps"].attrs["NSteps"]) == 2
        assert f["VTKHDF/PointData/u"][()].tolist() == [1.0, 1.0, 2.0, 2.0]
    writer.close()
    # frames never written before the close: the close creates the file and writes them
    (tmp_path / "once").mkdir()
    writer = paraview.ParaviewWriter(tmp_path / "once", mesh, every=None)
    writer.record(0.0, _frame(1.0))
    assert not (tmp_path / "once" / "beams.vtkhdf").exists()
    writer.close()
    with h5py.File(tmp_path / "once" / "beams.vtkhdf", "r") as f:
        assert int(f["VTKHDF/Steps"].attrs["NSteps"]) == 1 and f["VTKHDF/Steps/Values"][()].tolist() == [0.0]


def test_without_h5py_the_run_is_refused_at_its_first_frame_as_before(tmp_path):
    """h5py is a requirement; where it cannot be imported the run stops at its first frame (before any step),
    its state history in state.npz, as when the ParaView writer imported h5py with its first frame, not after
    every step at the first write of frames."""
    scene = tmp_path / "corner.yaml"
    scene.write_text(SCENE)
    code = textwrap.dedent("""
        import sys
        sys.modules["h5py"] = None  # not installed
        from latdyn.cli import main
        sys.exit(main(["run", *sys.argv[1:]]))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code, str(scene), "-o", str(tmp_path / "out"), "-q"],
                          capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 1 and "import of h5py halted" in done.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert (summary["status"], summary["steps"], summary["rows"], summary["state_file"]) == ("failed", 0, 1, "state.npz")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["probes.csv", "state.npz", "summary.json"]


def test_a_results_folder_whose_paraview_is_a_file_is_refused_at_the_first_frame_as_before(tmp_path):
    """The ParaView folder is made with the first frame (before any step), as when the file was created there:
    a file named ``paraview`` in the results folder stops the run at once, its state history written."""
    scene = tmp_path / "corner.yaml"
    scene.write_text(SCENE)
    out = tmp_path / "out"
    out.mkdir()
    (out / "paraview").write_text("not a folder")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 1 and "FileExistsError" in done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["status"], summary["steps"], summary["rows"]) == ("failed", 0, 1)
    assert "FileExistsError" in summary["error"] and (out / "state.h5").is_file()
