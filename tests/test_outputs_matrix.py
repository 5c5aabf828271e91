"""Every scene feature with every output file (issue 18 item 7; SCENE.md "Commands and results",
``output.paraview_every``): tiny scenes typed as YAML text, run through the CLI as a user does
(``python -m latdyn run SCENE -o OUT -q``) and a subset through ``latdyn.run(latdyn.load_scene(path))``.

Per run: exit 0 and ``summary.json`` status ``solved``; ``probes.csv`` header and rows as the
summary says; ``state.h5`` read with h5py, ``t`` as long as the summary's state rows; the ParaView
parts read back with VTK's ``vtkHDFReader`` (tests/vtkhdf_frames.py), as many frames as the
summary says, an empty part skipped (rigid-only scenes); ``paraview_every: 0`` writes no folder;
``modes.csv`` for modal runs. Transient runs of a few features are interrupted and resumed with
``latdyn run --resume``: the files equal the uninterrupted run's. The CLI runs are started
together (two at a time) once per module, so that the whole file stays fast.
"""
from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import latdyn
from latdyn.results.writer import Result
from test_checkpoint import assert_same_files, interrupt_at
from vtkhdf_frames import read_frames, times

h5py = pytest.importorskip("h5py")
pytest.importorskip("vtk")
ROOT = Path(__file__).resolve().parents[1]

SECTION = "  s: {EA: 1.0e5, EIy: 60.0, EIz: 90.0, GJ: 50.0, rhoA: 1.0, rhoIy: 1.0e-3, rhoIz: 1.0e-3}\n"

#: the features: the scene without its ``solve`` and ``output`` blocks, and its probes (YAML text)
FEATURES = {
    "cantilever": ("""\
title: plain 3D cantilever
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  b: {from: base, to: [1, 0.2, 0.1], section: s, elements: 2}
loads:
  - {at: b.end, force: [0, 2, 1.5], moment: [0.3, 0, 0]}
""", """\
    tip_y: {point: b.end, quantity: displacement, component: y}
    M: {element: b.element[0], quantity: moment_z}
    E: {energy: total}
"""),
    "body": ("""\
title: joint body with mass and inertia, and a beam from an offset grid point
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
  m: {at: [1, 0, 0], mass: 0.5, com: [0.02, 0, 0.01], inertia: [1.0e-3, 2.0e-3, 3.0e-3]}
beams:
  a: {from: base, to: m, section: s, elements: 2}
  c: {from: {body: m, offset: [0, 0.1, 0.05]}, to: [1.3, 0.3, 0.2], section: s}
loads:
  - {at: c.end, force: [0, 0, -2]}
""", """\
    m_z: {point: m, quantity: displacement, component: z}
    c_end: {point: c.end, quantity: position, frame: m, component: norm}
    Hx: {momentum: angular, component: x}
"""),
    "hinge_lock": ("""\
title: hinge with spring, damper and a lock, skew second link
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
  elbow: {at: [1, 0, 0], mass: 0.2, inertia: [1.0e-3, 1.0e-3, 1.0e-3]}
beams:
  a:
    from: base
    to: elbow
    section: s
    elements: 2
    start: {hinge: {axis: [0, 0, 1], stiffness: 5, damping: 0.05, torque: "20*t", lock_at: 0.0005}}
  b: {from: elbow, to: [1.2, 0.3, 0.2], section: s}
""", """\
    q: {hinge: a.start, quantity: angle}
    r: {hinge: a.start, quantity: rate}
    tip: {point: b.end, quantity: velocity, component: norm}
"""),
    "hinge_law": ("""\
title: hinge laws in theta and theta_dot
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  a:
    from: base
    to: [1, 0, 0.3]
    section: s
    elements: 2
    start:
      hinge: {axis: [0, 1, 0], stiffness: "2 + theta**2", damping: "0.1 + theta_dot**2", torque: "Min(t, 0.01)*50"}
loads:
  - {at: a.end, force: [0, 0.5, -1]}
""", """\
    q: {hinge: a.start, quantity: angle}
    E: {energy: strain}
"""),
    "rigid_only": ("""\
title: rigid link only, a body at its end
gravity: [0, -9.81, -3]
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
  bob: {at: [0.8, 0, 0.2], mass: 1.0, inertia: [1.0e-3, 1.0e-3, 1.0e-3]}
beams:
  link:
    from: base
    to: bob
    section: s
    rigid: true
    start: {hinge: {axis: [0, 0, 1], damping: 0.01}}
""", """\
    bob_y: {point: bob, quantity: position, component: y}
    q: {hinge: link.start, quantity: angle}
    E: {energy: total}
"""),
    "rigid_flex": ("""\
title: rigid link on a hinge that locks, then a flexible beam
gravity: [0, 0, -9.81]
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
  j: {at: [0.5, 0, 0], mass: 0.3, inertia: [1.0e-3, 1.0e-3, 1.0e-3]}
beams:
  link:
    from: base
    to: j
    section: s
    rigid: true
    start: {hinge: {axis: [0, 1, 0], torque: "-3", lock_at: 0.0008}}
  flex: {from: j, to: [1.0, 0.2, 0.1], section: s, elements: 2}
""", """\
    q: {hinge: link.start, quantity: angle}
    tip_z: {point: flex.end, quantity: position, component: z}
    F: {element: flex.element[1], quantity: axial_force}
"""),
    "prescribed": ("""\
title: hub in prescribed rotation about a skew axis
sections:
""" + SECTION + """\
bodies:
  hub:
    at: [0, 0, 0]
    motion:
      rotation: {axis: [0, 0.3, 1], angle: "2*t**2"}
beams:
  arm: {from: hub, to: [1, 0, 0], section: s, elements: 2}
""", """\
    tip_v: {point: arm.end, quantity: position, frame: hub, component: y}
    K: {energy: kinetic}
"""),
    "follower": ("""\
title: follower load in the frame of a joint body
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1, 0, 0], mass: 0.1}
beams:
  b: {from: base, to: tip, section: s, elements: 2}
loads:
  - {at: tip, force: [0, 1, 1], moment: [0.2, 0, 0], frame: tip}
""", """\
    tip_z: {point: tip, quantity: displacement, component: z}
    W: {energy: external_work}
"""),
    "gravity": ("""\
title: cantilever under skew gravity
gravity: [0, -9.81, -4]
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
  m: {at: [1, 0, 0], mass: 0.2}
beams:
  b: {from: base, to: m, section: s, elements: 2}
""", """\
    m_y: {point: m, quantity: displacement, component: y}
    P: {energy: potential}
"""),
    "shear": ("""\
title: Timoshenko section (GAy, GAz)
sections:
  s: {EA: 1.0e5, EIy: 60.0, EIz: 90.0, GJ: 50.0, GAy: 2.0e3, GAz: 3.0e3, rhoA: 1.0, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  b: {from: base, to: [0.5, 0, 0.2], section: s, elements: 2}
loads:
  - {at: b.end, force: [0, 3, 1]}
""", """\
    tip_y: {point: b.end, quantity: displacement, component: y}
    V: {element: b.element[0], quantity: moment_y}
"""),
    "planar": ("""\
title: planar frame (x-y plane)
gravity: [0, -9.81, 0]
sections:
""" + SECTION + """\
bodies:
  base: {at: [0, 0, 0], fixed: true}
  j: {at: [0.5, 0.5, 0], mass: 0.2}
beams:
  a: {from: base, to: j, section: s, elements: 2, start: {hinge: {axis: [0, 0, 1], stiffness: 10}}}
  b: {from: j, to: [1, 0.5, 0], section: s}
loads:
  - {at: b.end, force: [0.5, -1, 0]}
""", """\
    q: {hinge: a.start, quantity: angle}
    tip_y: {point: b.end, quantity: position, component: y}
"""),
}
FEATURES["planar_off"] = (FEATURES["planar"][0].replace("title: planar frame", "title: planar frame in 3D"),
                          FEATURES["planar"][1])
FEATURES["cr4402"] = (FEATURES["cantilever"][0].replace("title: plain", "title: cr4402"), FEATURES["cantilever"][1])
#: extra ``solve`` lines of a feature, typed as a user would (``off`` unquoted: a YAML 1.1 boolean)
SOLVE_EXTRA = {"planar_off": "  planar: off\n", "cr4402": "  formulation: cr4402\n"}

ANALYSIS = {
    "transient": "  analysis: transient\n  t_end: 0.02\n  dt: 0.005\n",
    "static": "  analysis: static\n  steps: 2\n",
    "modes": "  analysis: modes\n  count: 3\n",
}
#: (feature, analysis, output.paraview_every or None): every feature transient; static where the
#: loads have an equilibrium (not the free hinges of rigid_only, rigid_flex, prescribed); modes for a few
CASES = [(f, "transient", None) for f in FEATURES] + [
    (f, "static", None) for f in ("cantilever", "body", "hinge_law", "follower", "gravity", "shear", "planar_off",
                                  "cr4402")
] + [(f, "modes", None) for f in ("cantilever", "body", "rigid_only", "shear", "planar", "planar_off")] + [
    ("hinge_lock", "transient", "0"), ("rigid_only", "transient", "0.01"),
]
#: run through the Python API as well; probes.csv must equal the CLI's
API_CASES = [("body", "transient", None), ("rigid_only", "transient", None), ("hinge_law", "static", None),
             ("planar_off", "modes", None)]


def case_id(case) -> str:
    feature, analysis, every = case
    return f"{feature}-{analysis}" + (f"-pv{every}" if every is not None else "")


def scene_text(feature: str, analysis: str, every: str | None = None, solve: str | None = None) -> str:
    body, probes = FEATURES[feature]
    output = "output:\n" + (f"  paraview_every: {every}\n" if every is not None else "") + "  probes:\n" + probes
    return body + "solve:\n" + (solve or ANALYSIS[analysis]) + SOLVE_EXTRA.get(feature, "") + output


def cli(*args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "latdyn", *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=cwd, env={**os.environ, "PYTHONPATH": str(ROOT)})


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Every case of CASES through the CLI, two processes at a time: {case: (scene path, out, process)}."""
    root = tmp_path_factory.mktemp("matrix")

    def one(case):
        path = root / f"{case_id(case)}.yaml"
        path.write_text(scene_text(*case))
        out = root / f"{case_id(case)}_out"
        return case, (path, out, cli("run", path, "-o", out, "-q"))

    with ThreadPoolExecutor(2) as pool:
        return dict(pool.map(one, CASES))


def read_csv(path: Path) -> tuple[list[str], list[list[float]]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], [[float(v) for v in row] for row in rows[1:]]


def check_outputs(scene_path: Path, out: Path, analysis: str, every: str | None) -> dict:
    """The files of a solved run, each against the summary; returns the summary."""
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "solved" and summary["analysis"] == analysis

    header, rows = read_csv(out / "probes.csv")
    probes = [p.name for p in latdyn.load_scene(scene_path).output.probes]
    first = "load_factor" if analysis == "static" else "t"
    assert header == [first, *probes] == [summary["first_column"], *summary["probes"]]
    assert len(rows) == summary["rows"] and all(len(r) == len(header) for r in rows)
    assert (len(rows) == 0) == (analysis == "modes")  # a modal run: the header, no rows
    values = np.array(rows).reshape(len(rows), len(header))
    assert np.all(np.isfinite(values)), "NaN or inf in probes.csv"
    if analysis == "transient":
        assert values[0, 0] == 0.0 and values[-1, 0] == pytest.approx(0.02, abs=1e-12)
        assert np.all(np.diff(values[:, 0]) > 0)
    if analysis == "static":
        assert values[-1, 0] == pytest.approx(1.0)

    if summary.get("state_file"):  # the state history, read as a user would
        assert summary["state_file"] == "state.h5"
        with h5py.File(out / "state.h5", "r") as f:
            assert len(f["t"]) == summary["state_rows"]
            for name in f:
                assert len(f[name]) == summary["state_rows"], name
                assert np.all(np.isfinite(f[name][()])), name
            if analysis == "transient":
                np.testing.assert_array_equal(f["t"][()], values[:, 0])

    if analysis == "modes":
        header, rows = read_csv(out / "modes.csv")
        assert header[:2] == ["mode", "frequency_hz"]
        # the 3 lowest, or all there are (the rigid-only pendulum has one coordinate)
        assert [int(r[0]) for r in rows] == list(range(1, min(3, summary["coordinates"]) + 1))
        f = np.array([r[1] for r in rows])
        assert np.all(np.isfinite(f)) and np.all(f >= -1e-6) and np.all(np.diff(f) >= -1e-9)

    folder = out / "paraview"
    if every == "0":
        assert not folder.exists() and not summary.get("paraview_files")
        return summary
    files = summary.get("paraview_files") or []
    assert sorted(p.name for p in folder.iterdir()) == sorted(Path(p).name for p in files) if folder.exists() else not files
    for name in files:
        frames = read_frames(out / name)
        assert len(frames) == summary["paraview_frames"] > 0, name
        for frame in frames:
            assert frame.points.shape[0] > 0 and frame.cells, name
            assert np.all(np.isfinite(frame.points)), name
        if analysis == "transient":
            steps = times(out / name)
            assert steps[-1] == pytest.approx(0.02, abs=1e-12)  # the frame at t_end is always there
            if every == "0.01":
                assert steps == pytest.approx([0.0, 0.01, 0.02])
    return summary


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_cli_run_writes_every_output(case, runs):
    feature, analysis, every = case
    path, out, proc = runs[case]
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    summary = check_outputs(path, out, analysis, every)
    if every is None and analysis == "transient":  # the default: a frame per step here (4 steps)
        assert summary["paraview_frames"] == 5 <= summary["rows"]  # more rows where a hinge locks
    parts = {Path(p).name for p in summary.get("paraview_files") or []}
    if analysis == "modes":  # no state history, no frames
        f = np.array(read_csv(out / "modes.csv")[1])[:, 1]
        if feature == "rigid_only":  # a horizontal pendulum on a vertical axis: nothing restores it
            assert summary["coordinates"] == 1 and abs(f[0]) < 1e-6
        else:
            assert f[-1] > 0
        assert not summary.get("state_file") and not parts
    elif every != "0":
        # beams (rigid links drawn too) and joint bodies: each part written when non-empty
        assert "beams.vtkhdf" in parts
        assert ("bodies.vtkhdf" in parts) == ("bodies:" in FEATURES[feature][0])


def test_planar_scene_has_fewer_coordinates_than_planar_off(runs):
    planar = json.loads((runs["planar", "transient", None][1] / "summary.json").read_text())
    off = json.loads((runs["planar_off", "transient", None][1] / "summary.json").read_text())
    assert planar["coordinates"] < off["coordinates"]
    a = Result.load(runs["planar", "transient", None][1]).probes
    b = Result.load(runs["planar_off", "transient", None][1]).probes
    for k in a:  # the same motion, in fewer coordinates
        np.testing.assert_allclose(a[k], b[k], rtol=1e-6, atol=1e-9)


def test_formulation_is_reported(runs):
    assert json.loads((runs["cr4402", "static", None][1] / "summary.json").read_text())["formulation"] == "cr4402"


def test_hinge_locks_in_the_transient_runs(runs):
    q = Result.load(runs["hinge_lock", "transient", None][1]).probes["q"]
    assert q[-1] == pytest.approx(0.0005, abs=1e-7)
    q = Result.load(runs["rigid_flex", "transient", None][1]).probes["q"]
    assert abs(q[-1]) == pytest.approx(0.0008, abs=1e-7)


@pytest.mark.parametrize("case", API_CASES, ids=case_id)
def test_python_api_writes_the_same_files(case, runs, tmp_path):
    path, cli_out, _ = runs[case]
    out = tmp_path / "out"
    result = latdyn.run(latdyn.load_scene(path), out)
    check_outputs(path, out, case[1], case[2])
    assert (out / "probes.csv").read_text() == (cli_out / "probes.csv").read_text()
    if case[1] == "modes":
        assert (out / "modes.csv").read_text() == (cli_out / "modes.csv").read_text()
    else:
        assert len(result.t) == json.loads((out / "summary.json").read_text())["rows"]


#: transient runs of 10 steps, interrupted at t_stop (before the hinge locks) and resumed by the CLI
RESUME = {"rigid_flex": 0.015, "hinge_lock": 0.01, "hinge_law": 0.025}


@pytest.mark.parametrize("feature", sorted(RESUME))
def test_interrupted_run_resumed_by_the_cli_equals_the_uninterrupted_one(feature, tmp_path, monkeypatch):
    path = tmp_path / "scene.yaml"
    path.write_text(scene_text(feature, "transient", solve="  t_end: 0.05\n  dt: 0.005\n"))
    full, out = tmp_path / "full", tmp_path / "out"
    proc = cli("run", path, "-o", full, "-q")
    assert proc.returncode == 0, proc.stderr
    with monkeypatch.context() as m:
        interrupt_at(m, RESUME[feature])
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(latdyn.load_scene(path), out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["checkpoint_t"] == pytest.approx(RESUME[feature])
    proc = cli("run", path, "-o", out, "-q", "--resume")
    assert proc.returncode == 0, proc.stderr
    assert_same_files(full, out)
    if feature != "hinge_law":  # the lock came after the checkpoint
        r = Result.load(out)
        q = r.probes["q"]
        lock = {"rigid_flex": 0.0008, "hinge_lock": 0.0005}[feature]
        assert np.all(np.abs(q[r.t <= RESUME[feature]]) < lock - 1e-5)  # not yet locked at the checkpoint
        assert abs(q[-1]) == pytest.approx({"rigid_flex": 0.0008,
                                                                         "hinge_lock": 0.0005}[feature], abs=1e-7)


@pytest.mark.parametrize("value", ["-1", "off"])
def test_bad_paraview_every_exits_2_naming_file_and_key(value, tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(scene_text("cantilever", "transient", every=value))
    proc = cli("run", path, "-o", tmp_path / "out", "-q")
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr
    assert "bad.yaml" in proc.stderr and "output.paraview_every" in proc.stderr
    assert "got False" not in proc.stderr
    assert not (tmp_path / "out" / "summary.json").exists()
