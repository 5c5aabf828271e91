"""Studies (shared/STUDY.md): validation before anything runs, statuses, the case cache,
the error norms, and the same rows from a real 2-worker Dask LocalCluster as from serial.

Every study here is the spin-up scene cut to a few steps on 2 elements (seconds).
"""
from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn import cli
from latdyn.errors import SceneError
from latdyn.studies.case import _energy_status
from latdyn.studies.runner import StudyTable, case_error, load_study
from latdyn.studies.cluster import parse_scheduler

ROOT = Path(__file__).resolve().parents[1]
SPINUP = ROOT / "examples" / "spinup.yaml"

#: 3 methods × 2 steps on 2 elements, 0.16 s of the spin-up: newmark and generalized-alpha
#: solve, the explicit method is far above its stability limit (about 1e-3 s here) and blows up.
SMALL = {
    "title": "small spin-up study",
    "scene": str(SPINUP),
    "set": {"solve.t_end": 0.16, "beams.arm.elements": 2, "output.every": 0.04, "output.paraview_every": 0},
    "vary": {"solve.dt": [0.04, 0.02], "solve.method": ["generalized-alpha", "newmark", "explicit"]},
    "reference": {"overrides": {"solve.dt": 0.01, "solve.method": "newmark"}},
    "error": {"probe": "tip_v", "norm": "max"},
}


def _write(tmp_path, study: dict, name="study.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(study, sort_keys=False))
    return path


def _rows(path: Path, drop=("wall_s",)) -> list[dict]:
    with open(path, newline="") as f:
        return [{k: v for k, v in row.items() if k not in drop} for row in csv.DictReader(f)]


# ----------------------------------------------------------------------------- validation
@pytest.mark.parametrize("change, key, words", [
    ({"colour": "red"}, "colour", "unknown key"),
    ({"vary": {"beams.nope.elements": [2, 4]}}, "vary.beams.nope.elements", "no 'nope'"),
    ({"vary": {"solve.dt": ["fast", 0.01]}}, "vary.solve.dt[0]", "expected"),
    ({"vary": {"solve.dt": 0.01}}, "vary.solve.dt", "list"),
    ({"vary": {"solve.rhoinf": [0.5]}}, "vary.solve.rhoinf", "rhoinf"),
    ({"vary": {"solve.dt": [0.01, 5.0]}}, "vary.solve.dt[1]", "t_end"),
    ({"error": {"probe": "nothing", "norm": "max"}}, "error.probe", "tip_v"),
    ({"error": {"probe": "tip_v", "norm": "l2"}}, "error.norm", "max, rms, final"),
    ({"repeats": 0}, "repeats", "whole number"),
    ({"reference": {"overrides": {"beams.arm.elements": 2.5}}}, "reference.overrides.beams.arm.elements", ""),
    ({"stability": ["solve.dt", "solve.dt"]}, "stability", "two different"),
])
def test_invalid_study_exits_2_naming_file_and_key(tmp_path, capsys, change, key, words):
    study = dict(SMALL, **change)
    path = _write(tmp_path, study)
    out = tmp_path / "out"
    assert cli.main(["study", str(path), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: {key}:" in err, err
    assert words in err, err
    assert not (out / "cases").exists()  # nothing ran


def test_bad_scheduler_exits_2_before_running(tmp_path, capsys):
    path = _write(tmp_path, SMALL)
    assert cli.main(["study", str(path), "-o", str(tmp_path / "out"), "--scheduler", "local:0", "-q"]) == 2
    assert "local:N" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    assert parse_scheduler("serial") == ("serial",)
    assert parse_scheduler("local:3") == ("local", 3)
    assert parse_scheduler("tcp://10.0.0.1:8786") == ("address", "tcp://10.0.0.1:8786")
    with pytest.raises(ValueError):
        parse_scheduler("local:two")


def test_missing_study_file_exits_2(tmp_path, capsys):
    assert cli.main(["study", str(tmp_path / "none.yaml")]) == 2
    assert "no such study file" in capsys.readouterr().err


def test_vary_paths_index_lists_and_defaults(tmp_path):
    d2 = ROOT / "examples" / "benchmarks" / "D2_right_angle_cantilever.yaml"
    spec = load_study({"scene": str(d2), "vary": {"loads[0].force[2]": [1.0, 2.0], "solve.rho_inf": [0.5, 1.0]},
                       "reference": {"overrides": {}}, "error": {"probe": "tip_u3"}})
    assert spec.numeric_keys == ["loads[0].force[2]", "solve.rho_inf"]
    with pytest.raises(SceneError, match=r"vary\.loads\[3\]\.force: the scene has no item \[3\]"):
        load_study({"scene": str(d2), "vary": {"loads[3].force": [[0, 0, 1]]},
                    "reference": {"overrides": {}}, "error": {"probe": "tip_u3"}})


# ----------------------------------------------------------------------------- pure functions
def test_error_norms_over_common_times_and_interpolated():
    t_ref = np.linspace(0.0, 1.0, 11)
    v_ref = t_ref ** 2
    t = np.array([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    v = t ** 2 + np.array([0, 1, -3, 2, 0, 0.5]) * 1e-3
    assert case_error(t, v, t_ref, v_ref, "max") == pytest.approx(3e-3)
    assert case_error(t, v, t_ref, v_ref, "final") == pytest.approx(5e-4)
    assert case_error(t, v, t_ref, v_ref, "rms") == pytest.approx(math.sqrt((1 + 9 + 4 + 0.25) * 1e-6 / 6))
    # no common times but t = 0: the reference is interpolated onto the case's times
    t_odd = np.array([0.0, 0.15, 0.55])
    expected = np.max(np.abs(t_odd ** 2 - np.interp(t_odd, t_ref, v_ref)))
    assert case_error(t_odd, t_odd ** 2, t_ref, v_ref, "max") == pytest.approx(expected)
    assert expected > 0


def test_energy_rule():
    t = np.linspace(0, 1, 5)
    zero = np.zeros(5)
    work = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    # energy equal to the work put in (a driven structure): bounded
    assert _energy_status(t, {"_study_K": work, "_study_S": zero, "_study_P": zero, "_study_W": work}) is None
    # numerical dissipation: bounded
    assert _energy_status(t, {"_study_K": 0.5 * work, "_study_S": zero, "_study_P": zero, "_study_W": work}) is None
    # more than twice the work: energy created by the integrator
    grow = np.array([0.0, 1.0, 3.0, 9.0, 27.0])
    assert _energy_status(t, {"_study_K": grow, "_study_S": zero, "_study_P": zero, "_study_W": work}) == "unbounded"
    # a free vibration that grows from its initial energy
    free = np.array([1.0, 1.0, 1.5, 2.5, 8.0])
    assert _energy_status(t, {"_study_K": free, "_study_S": zero, "_study_P": zero, "_study_W": zero}) == "unbounded"
    assert _energy_status(t, {"_study_K": zero + 1, "_study_S": zero, "_study_P": zero, "_study_W": zero}) is None
    # nothing ever received: judged on finite values only
    assert _energy_status(t, {"_study_K": zero, "_study_S": zero, "_study_P": zero, "_study_W": zero}) is None


# ----------------------------------------------------------------------------- running studies
@pytest.fixture(scope="module")
def serial_study(tmp_path_factory):
    folder = tmp_path_factory.mktemp("study")
    path = _write(folder, SMALL)
    out = folder / "serial"
    assert cli.main(["study", str(path), "-o", str(out), "-q"]) == 0
    return path, out


def test_serial_study_rows_statuses_and_files(serial_study):
    _, out = serial_study
    rows = _rows(out / "study.csv", drop=())
    assert list(rows[0])[:9] == ["solve.dt", "solve.method", "status", "error", "wall_s", "steps",
                                 "newton_iterations", "rejected_steps", "coordinates"]
    assert [(r["solve.dt"], r["solve.method"]) for r in rows] == [
        ("0.04", "generalized-alpha"), ("0.04", "newmark"), ("0.04", "explicit"),
        ("0.02", "generalized-alpha"), ("0.02", "newmark"), ("0.02", "explicit")]
    by = {(r["solve.dt"], r["solve.method"]): r for r in rows}
    for dt in ("0.04", "0.02"):
        for method in ("generalized-alpha", "newmark"):
            r = by[dt, method]
            assert r["status"] == "solved"
            assert 0 < float(r["error"]) < 1e-2
            assert float(r["wall_s"]) > 0
            assert int(r["steps"]) == round(0.16 / float(dt))
            assert int(r["newton_iterations"]) >= int(r["steps"])
            assert int(r["coordinates"]) > 0
        r = by[dt, "explicit"]
        assert r["status"] == "unbounded", r
        assert r["error"] == ""
        assert "energy" in r["message"] or "finite" in r["message"] or "unstable" in r["message"], r
    # newmark at half the step is closer to the (newmark) reference
    assert float(by["0.02", "newmark"]["error"]) < float(by["0.04", "newmark"]["error"])
    for row in rows:
        assert (out / "cases" / row["case"] / "case.json").is_file()
        assert (out / "cases" / row["case"] / "probes.csv").is_file()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["statuses"] == {"solved": 4, "failed": 0, "unbounded": 2}
    assert summary["scheduler"]["kind"] == "serial"
    assert summary["machine"]["cores"] >= 1 and "versions" in summary and summary["wall_time_s"] > 0
    assert summary["ran"] == 7  # 6 cases and the reference
    for picture in ("work_precision.png", "stability.png"):
        assert (out / picture).stat().st_size > 10_000


def test_rerun_reuses_the_cache_and_runs_only_what_is_missing(serial_study, tmp_path):
    path, out = serial_study
    before = _rows(out / "study.csv", drop=())
    table = latdyn.study(str(path), out=str(out), progress=False)
    assert table.summary["ran"] == 0 and table.summary["reused"] == 7
    again = StudyTable.read_csv(out / "study.csv")
    assert again.columns == table.columns and again["solve.dt"] == [0.04] * 3 + [0.02] * 3
    assert again["status"] == table["status"] and again["steps"] == table["steps"]
    assert [dict(r, wall_s=None) for r in _rows(out / "study.csv", drop=())] == [dict(r, wall_s=None) for r in before]
    assert [r["wall_s"] for r in _rows(out / "study.csv", drop=())] == [r["wall_s"] for r in before]
    # a case deleted: only it runs again
    victim = out / "cases" / before[1]["case"] / "case.json"
    victim.unlink()
    table = latdyn.study(str(path), out=str(out), progress=False)
    assert table.summary["ran"] == 1
    assert victim.is_file()
    assert _rows(out / "study.csv") == [{k: v for k, v in r.items() if k != "wall_s"} for r in before]


def test_failed_case_is_a_row(tmp_path):
    study = dict(SMALL, vary={"solve.max_iterations": [1, 20]},
                 set={"solve.t_end": 0.08, "beams.arm.elements": 2, "solve.dt": 0.04, "solve.dt_min": 0.04},
                 reference={"overrides": {"solve.dt": 0.02, "solve.dt_min": 0.02}})
    table = latdyn.study(study, out=tmp_path / "out", progress=False)
    failed, solved = table.rows
    assert failed["status"] == "failed" and "SolverError" in failed["message"]
    assert math.isnan(failed["error"]) and failed["steps"] < 2 and failed["rejected_steps"] >= 1
    assert failed["t_reached"] < 0.08
    assert solved["status"] == "solved" and solved["error"] > 0
    assert table["solve.max_iterations"] == [1, 20]
    csv_rows = _rows(tmp_path / "out" / "study.csv")
    assert csv_rows[0]["status"] == "failed" and csv_rows[0]["error"] == ""


SENSITIVE_ARM = """\
parameters: {P: 1.0}
sections: {s: {EA: 1.0e6, EIy: 100.0, EIz: 100.0, GJ: 80.0, rhoA: 1.0}}
bodies: {base: {at: [0, 0, 0], fixed: true}}
beams: {arm: {from: base, to: [1, 0.3, 0.2], section: s, elements: 4}}
loads: [{at: arm.end, force: [0, "-P", 0]}]
solve: {analysis: transient, dt: 0.001, t_end: 0.004, sensitivities: [P]}
output: {probes: {tip: {point: arm.end, quantity: displacement, component: y}}}
"""


def test_a_case_the_run_refuses_is_a_failed_row_naming_the_scene_and_key(tmp_path):
    """A varied value the model or an analysis refuses only when the case is prepared (here the explicit
    method with sensitivities) is a failed row whose message names the scene's file and key, not an
    "internal error" of a "<dict>"."""
    scene = tmp_path / "arm.yaml"
    scene.write_text(SENSITIVE_ARM)
    study = _write(tmp_path, {"scene": str(scene), "vary": {"solve.method": ["newmark", "explicit"]},
                              "reference": {"overrides": {"solve.dt": 0.0005}}, "error": {"probe": "tip", "norm": "max"}})
    assert cli.main(["study", str(study), "-o", str(tmp_path / "out")]) == 0
    solved, refused = _rows(tmp_path / "out" / "study.csv")
    assert solved["status"] == "solved"
    assert refused["status"] == "failed"
    assert refused["message"].startswith(f"refused: {scene}: solve.sensitivities: ")
    assert "internal error" not in refused["message"] and "<dict>" not in refused["message"]


def test_local_cluster_gives_the_same_rows_as_serial(serial_study, tmp_path):
    pytest.importorskip("distributed")
    path, serial_out = serial_study
    out = tmp_path / "dask"
    table = latdyn.study(str(path), scheduler="local:2", out=str(out), progress=False)
    assert table.summary["scheduler"]["kind"] == "local" and table.summary["scheduler"]["workers"] == 2
    assert table.summary["ran"] == 7
    assert _rows(out / "study.csv") == _rows(serial_out / "study.csv")
    # the cases ran in the two worker processes themselves (no process of their own)
    pids = {json.loads((out / "cases" / r["case"] / "case.json").read_text())["pid"] for r in table.rows}
    assert os.getpid() not in pids and 1 <= len(pids) <= 2


def test_a_client_of_ones_own_cluster_gives_the_same_rows_and_stays_open(serial_study, tmp_path):
    distributed = pytest.importorskip("distributed")
    path, serial_out = serial_study
    out = tmp_path / "client"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        table = latdyn.study(str(path), client=client, out=str(out), progress=False)
        assert client.status == "running"  # the caller's client is not closed
        assert client.submit(sum, [1, 2]).result() == 3
    assert table.summary["scheduler"]["kind"] == "client" and table.summary["scheduler"]["workers"] == 2
    assert table.summary["ran"] == 7
    assert _rows(out / "study.csv") == _rows(serial_out / "study.csv")


def test_client_argument_is_checked_before_anything_runs(tmp_path):
    with pytest.raises(ValueError, match="dask.distributed.Client"):
        latdyn.study(SMALL, client=object(), out=tmp_path / "out", progress=False)
    with pytest.raises(ValueError, match="not both"):
        latdyn.study(SMALL, scheduler="local:2", client=object(), out=tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


def test_a_case_that_kills_its_worker_is_a_failed_row_after_the_retries(tmp_path):
    """The worker dies under the case every time: the nanny restarts it, the scheduler
    reschedules the case (allowed-failures), then gives up; the row says so and the other
    case still comes back."""
    distributed = pytest.importorskip("distributed")
    import dask

    from latdyn.studies.cluster import open_scheduler

    def case(task):  # pickled by value (a local function); runs in the worker process
        if task["hash"] == "crash":
            os._exit(3)
        return {"hash": task["hash"], "status": "solved", "pid": os.getpid()}

    # one task at a time on a worker (as on local:N), so that only the crashing case is blamed
    with dask.config.set({"distributed.scheduler.allowed-failures": 1, "distributed.scheduler.worker-saturation": 1.0}):
        cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                                           silence_logs=50)
        try:
            with distributed.Client(cluster) as client, open_scheduler(("client", client)) as runner:
                done = {task["hash"]: record for task, record in
                        runner.run(case, [{"hash": "crash", "overrides": {"solve.dt": 1.0}}, {"hash": "fine"}])}
        finally:
            try:
                cluster.close()
            except AssertionError as exc:  # distributed's nanny may still be restarting the killed worker
                if "can only join a started process" not in str(exc):  # (a race in distributed's teardown,
                    raise                                                # seen under load; not latdyn's)
    assert done["fine"]["status"] == "solved" and done["fine"]["pid"] != os.getpid()
    lost = done["crash"]
    assert lost["status"] == "failed" and lost["message"].startswith("worker lost: KilledWorker"), lost
    assert lost["overrides"] == {"solve.dt": 1.0} and lost["wall_s"] is None


def test_study_keeps_the_callers_matplotlib_backend(serial_study):
    """A study that draws its pictures leaves matplotlib's backend as the caller set it."""
    import matplotlib

    path, out = serial_study
    before = matplotlib.get_backend()
    try:
        matplotlib.use("svg")  # not Agg, which is what a global switch would leave
        (out / "stability.png").unlink()
        latdyn.study(str(path), out=str(out), progress=False)  # every case reused, pictures redrawn
        assert matplotlib.get_backend() == "svg"
        assert (out / "stability.png").stat().st_size > 10_000
    finally:
        matplotlib.use(before)


def test_the_dask_side_does_not_import_the_runner():
    import subprocess
    import sys

    code = ("import sys, latdyn.studies.cluster, latdyn.studies.case; "
            "assert 'latdyn.studies.runner' not in sys.modules, sorted(m for m in sys.modules if 'latdyn' in m)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


def test_peer_points_from_peers_json(tmp_path):
    from latdyn.studies.plots import _peer_points

    spec = load_study(dict(SMALL, peers=["exudyn"]))
    points, note = _peer_points(spec, tmp_path / "peers.json")
    assert points == [] and "peers.json not found" in note
    rows = [{"problem": "spinup", "code": "exudyn", "setting": "n=8 dt=0.01", "status": "ok", "error": 2e-4,
             "solver_s": 0.5},
            {"problem": "spinup", "code": "exudyn", "setting": "n=8 dt=0.04", "status": "failed", "error": None,
             "solver_s": None},
            {"problem": "spinup", "code": "latdyn", "setting": "n=8 dt=0.01", "status": "ok", "error": 1e-4,
             "solver_s": 1.5},
            {"problem": "cantilever", "code": "exudyn", "setting": "x", "status": "ok", "error": 1e-3,
             "solver_s": 0.1}]
    (tmp_path / "peers.json").write_text(json.dumps({
        "schema": "latdyn-peers/1", "created": "2026-11-23", "rows": rows,
        "problems": {"spinup": {"error": "max of |v(5)-v5_ref| ..."}}}))
    points, note = _peer_points(spec, tmp_path / "peers.json")
    assert [(p["peer"], p["wall_s"], p["error"]) for p in points] == [("exudyn", 0.5, 2e-4), ("latdyn", 1.5, 1e-4)]
    assert "not the study's norm" in note.replace("\n", " ")
