"""One case of a study, run where the scheduler puts it (see :mod:`latdyn.studies.runner`).

:func:`run_case` is the whole of a case's execution: the warm-up (once per process and
formulation), ``repeats`` timed runs of :func:`latdyn.run` into the case's folder, the
status from the run's own records (``solved``, ``failed``, ``unbounded``: the rules are in
:mod:`latdyn.studies.runner`'s docstring) and ``case.json``, written last and atomically.
It never raises for what a run does, so it is the same function in the study's process
(``serial``) and in a Dask worker (:mod:`latdyn.studies.cluster`, which imports nothing of the
runner). :func:`cached_record` reads a finished case back; :func:`failed_record` is the
row of a case that never returned (its worker was lost), which is not cached.
"""
from __future__ import annotations

import contextlib
import copy
import io
import json
import os
import platform
import shutil
import statistics
import threading
import time
from pathlib import Path

import numpy as np

from latdyn.errors import SceneError, SolverError, UnboundedError

__all__ = ["run_case", "cached_record", "failed_record", "STATUSES", "ENERGY_PROBES", "CASE_FILE"]

STATUSES = ("solved", "failed", "unbounded")
CASE_FILE = "case.json"
#: Energy probes added to every transient case (names a scene may not take: refused by load_study).
ENERGY_PROBES = {"_study_K": "kinetic", "_study_S": "strain", "_study_P": "potential", "_study_W": "external_work"}


_WARMED: set = set()
#: One case at a time in a process: ``stderr`` is redirected and BLAS pinned process-wide
#: while a case runs, and its ``wall_s`` must not include another case's work.
_CASE_LOCK = threading.Lock()


def _warm_up(raw: dict, backend: str) -> None:
    """Load (compile) the kernels and every first-use path once per process: the case cut
    to two steps, run without files. Its failure does not matter here."""
    from latdyn.model.kernels import load_kernels
    from latdyn.solve import run

    solve = raw.get("solve") or {}
    key = (solve.get("formulation", "default"), backend, solve.get("method", "generalized-alpha"))
    if key in _WARMED:
        return
    _WARMED.add(key)
    with contextlib.suppress(Exception):
        load_kernels(backend=backend, variant=key[0])
    short = copy.deepcopy(raw)
    if solve.get("analysis", "transient") == "transient":
        short["solve"]["t_end"] = 2 * float(short["solve"]["dt"])
        short.setdefault("output", {})["every"] = None
    with contextlib.redirect_stderr(io.StringIO()), contextlib.suppress(Exception):
        run(short, out_dir=None, backend=backend)


def _energy_status(t, probes: dict, round_off: float = 0.0) -> str | None:
    """``unbounded`` by the energy rule of the module docstring, else None. Rows whose received energy
    is within ``round_off`` (the run's floor, :func:`latdyn.timeloop.progress.energy_round_off`) received
    none: a structure at rest is never judged on round-off over round-off."""
    if not all(name in probes for name in ENERGY_PROBES) or len(t) == 0:
        return None
    return "unbounded" if np.any(_energy_rule_broken(probes, round_off)) else None


def _energy_onset(t, probes: dict, round_off: float = 0.0) -> float | None:
    """The first recorded time at which the energy rule holds (see :func:`_energy_status`)."""
    hit = np.flatnonzero(_energy_rule_broken(probes, round_off))
    return float(t[hit[0]]) if len(hit) else None


def _energy_rule_broken(probes: dict, round_off: float) -> np.ndarray:
    """Per recorded row: a non-finite energy, or ``created > received`` where ``received`` passed
    ``round_off``."""
    K, S, P, W = (np.asarray(probes[name], float) for name in ENERGY_PROBES)
    created = (K + S + P) - (K[0] + S[0] + P[0]) - W
    received = K[0] + S[0] + np.maximum.accumulate(np.abs(W)) + np.maximum.accumulate(np.abs(P - P[0]))
    finite = np.isfinite(created) & np.isfinite(received)
    return ~finite | ((received > round_off) & (created > received))


def _round_off(raw: dict) -> float:
    """The round-off of the energies of the case's structure at rest (the run's floor,
    :func:`latdyn.timeloop.progress.energy_round_off`); 0 for a scene that does not build (the run
    reports that)."""
    from latdyn.model.model import Model
    from latdyn.scene.loader import load_scene
    from latdyn.timeloop.progress import energy_round_off

    try:
        return energy_round_off(Model.from_scene(load_scene(copy.deepcopy(raw))))
    except Exception:  # noqa: BLE001 - the case's run reports what is wrong with its scene
        return 0.0


def _clear(folder: Path) -> None:
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)


def run_case(task: dict) -> dict:
    """Run one case (``task``: ``raw`` scene mapping, ``dir``, ``repeats``, ``backend``) and
    return its record, which is also written to ``dir/case.json``.

    Never raises for what a run does: a failure is a status. Every scheduler calls this
    function where the case runs: the serial one in the study's process, Dask in a worker's
    task thread (:mod:`latdyn.studies.cluster`). It holds BLAS to one thread, and a process-wide
    lock, so that a worker with several threads still runs one case at a time and
    ``wall_s`` (measured here, around :func:`latdyn.run`) is the case's alone.
    """
    from threadpoolctl import threadpool_limits

    from latdyn.errors import ResultsError
    from latdyn.results.result import Result
    from latdyn.solve import run
    from latdyn.version import __version__

    folder = Path(task["dir"])
    raw, repeats, backend = task["raw"], int(task.get("repeats", 1)), task.get("backend", "auto")
    record = {"hash": task["hash"], "overrides": task.get("overrides", {}), "latdyn_version": __version__,
              "status": None, "message": "", "wall_times": [], "steps": None, "newton_iterations": None,
              "rejected_steps": None, "coordinates": None, "t_reached": None, "host": platform.node(),
              "pid": os.getpid()}
    with _CASE_LOCK, threadpool_limits(limits=1):
        _warm_up(raw, backend)
        for attempt in range(repeats):
            _clear(folder)
            log = io.StringIO()
            error = None
            t0 = time.perf_counter()
            try:
                with contextlib.redirect_stderr(log):
                    run(copy.deepcopy(raw), out_dir=str(folder), backend=backend, progress=False,
                        checkpoint_every=1e9)
            except SolverError as exc:
                error = exc
            except Exception as exc:  # noqa: BLE001 - any failure of a case is a row, never a crash
                error = exc
            wall = time.perf_counter() - t0
            (folder / "stderr.txt").write_text(log.getvalue(), encoding="utf-8")
            try:
                result = Result.load(folder)
                summary, t, probes = result.summary, result.t, result.probes
            except ResultsError:
                summary, t, probes = {}, np.zeros(0), {}
            compile_s = summary.get("compile_s") or 0.0
            record["wall_times"].append(max(wall - float(compile_s), 0.0))
            if error is not None:
                break
    for key in ("steps", "newton_iterations", "rejected_steps", "coordinates"):
        record[key] = summary.get(key)
    record["t_reached"] = float(t[-1]) if len(t) else None
    values_finite = all(np.all(np.isfinite(v)) for v in probes.values()) if probes else True
    round_off = _round_off(raw)
    energy = _energy_status(t, probes, round_off)
    if not values_finite or energy:
        record["status"] = "unbounded"
        onset = _energy_onset(t, probes, round_off) if energy else None
        record["message"] = ("a recorded value is not finite" if not values_finite else
                             "the integrator created more energy than the structure received"
                             + (f" (from t = {onset:.6g})" if onset is not None else ""))
        if error is not None:
            record["message"] += f"; then {type(error).__name__}: {_first_line(error)}"
    elif error is not None:
        unstable = isinstance(error, UnboundedError) or (isinstance(error, SolverError)
                                                          and "became unstable" in str(error))
        record["status"] = "unbounded" if unstable else "failed"
        record["message"] = _error_message(error, task.get("scene_file"))
    else:
        record["status"] = "solved"
    record["wall_s"] = statistics.median(record["wall_times"])
    _write_json(folder / CASE_FILE, record)
    return record


def _error_message(error: BaseException, scene_file: str | None) -> str:
    """A failed case's message: a scene the run refused (a value the study varied that the model or an
    analysis does not take, found when the case is prepared) as ``refused: FILE: KEY: expected …`` with
    the scene's file for the ``<dict>`` the case ran from; a solver's failure by its class; anything else
    as an internal error."""
    if isinstance(error, SceneError):
        file = scene_file if error.file in ("<dict>", "<scene>") and scene_file else error.file
        return f"refused: {file}: {error.key}: {error.expected}"
    prefix = "" if isinstance(error, SolverError) else "internal error: "
    return f"{prefix}{type(error).__name__}: {_first_line(error)}"


def _first_line(error: BaseException) -> str:
    text = str(error).strip()
    return text.splitlines()[0] if text else ""


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, default=_json_default) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def cached_record(folder: Path, digest: str, repeats: int) -> dict | None:
    """The finished record in ``folder`` when it is of this case and has enough timings."""
    path = folder / CASE_FILE
    if not path.is_file():
        return None
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if record.get("hash") != digest or record.get("status") not in STATUSES:
        return None
    if record["status"] == "solved" and len(record.get("wall_times", [])) < repeats:
        return None
    return record


def failed_record(task: dict, message: str) -> dict:
    """The row of a case that did not come back (its worker process was lost); not cached."""
    return {"hash": task["hash"], "overrides": task.get("overrides", {}), "status": "failed", "message": message,
            "wall_times": [], "wall_s": None, "steps": None, "newton_iterations": None, "rejected_steps": None,
            "coordinates": None, "t_reached": None}
