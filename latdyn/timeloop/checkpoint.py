"""Checkpoints of a transient run: write, read and validate (SCENE.md, ``latdyn run --resume``).

A checkpoint is ``OUT/checkpoint.npz``, written atomically (temp file, fsync,
``os.replace``) at accepted-step boundaries: every ``interval`` seconds of wall
time, and when the run is interrupted (Ctrl-C, SIGTERM) or fails (the last
accepted step). It holds what the time loop needs to go on as if it had never
stopped:

* the :class:`latdyn.timeloop.progress.TransientProgress` (state of every node and hinge with
  its accelerations, the integrator's algorithmic acceleration, the step size to
  try next, grid and output indices, latched hinges, work and energy bookkeeping,
  counters, cut times),
* the probes' ``external_work``,
* modified Newton's held factorization (compiled step, ``solve.newton: modified``):
  the step size it belongs to and the factorized iteration matrix with its pivots
  (:meth:`latdyn.step.compiled.CompiledGeneralizedAlpha.factorization_state`), so that the
  resumed run reuses the matrix where the uninterrupted one does; none with full
  Newton or the explicit method, and none where the next step
  rebuilds it anyway (no factorization held, a latch just renumbered the
  coordinates, the inertia tangent was just switched on),
* the result writer's bookmark (:meth:`latdyn.results.writer.ResultWriter.bookmark`:
  rows, state rows and ParaView frames recorded), and the state of the last
  recorded row when its ParaView frame is not on disk yet (written at the end),
* its identity: format version, package version, scene hash, formulation, method,
  kernel backend, and how many times the run was resumed already.

The file is an NPZ of plain arrays plus one JSON document (no pickle: loading a
checkpoint runs no code). Floats go through JSON as ``repr``, which round-trips
float64 exactly, so a resumed run continues bit for bit.

One case is not bit for bit: the factorization is taken from the engine when the
checkpoint is written, and only while the engine still holds the last accepted
step's. A checkpoint written after the engine moved on carries none, and the
resumed run factorizes at its first step where the uninterrupted one reused the
held matrix (its results then differ within the Newton tolerance). That happens
when an interrupt or a failure arrives after a step began (the steps it took since
the last accepted one are not in the checkpoint anyway), or when a periodic
checkpoint falls on a row where the compiled loop of steps gave back a step that
factorized or failed (a hinge event, a Newton failure). An interrupt between steps
(Ctrl-C or SIGTERM delivered in Python), and periodic checkpoints otherwise, are exact.

A checkpoint of another format, package version, scene, formulation, method or
backend is refused with :class:`CheckpointError` (exit status 2), naming the file
and what differed. A run that finishes removes its checkpoint.
"""
from __future__ import annotations

import dataclasses
import io
import json
import os
import time
from pathlib import Path

import numpy as np

from latdyn.records import record

__all__ = ["CHECKPOINT_FILE", "FORMAT_VERSION", "DEFAULT_INTERVAL", "Checkpoint", "CheckpointError",
           "Checkpointer", "check", "discard", "identity", "load"]

CHECKPOINT_FILE = "checkpoint.npz"
#: 2: the held factorization of modified Newton (``factorization``); 1: before it (refused)
FORMAT_VERSION = 2
#: default wall-clock seconds between two checkpoints
DEFAULT_INTERVAL = 60.0
_META_KEY = "__meta__"


class CheckpointError(ValueError):
    """No usable checkpoint to resume from: exit status 2, message on stderr."""


@record
class Checkpoint:
    """What a checkpoint holds (see the module docstring)."""

    progress: object  # latdyn.timeloop.progress.TransientProgress
    external_work: float
    writer: dict  # ResultWriter.bookmark()
    last_recorded: object | None  # State of the last recorded row when its ParaView frame is unwritten
    identity: dict  # format, latdyn_version, scene_hash, formulation, method, backend
    resumes: int = 0  # how many times the run had been resumed when this was written
    #: modified Newton's held factorization (step.compiled.CompiledGeneralizedAlpha.factorization_state), or None
    factorization: dict | None = None

    @property
    def t(self) -> float:
        return float(self.progress.state.t)


def identity(scene, backend: str | None = None) -> dict:
    """What a checkpoint must match to be resumed by this run (the backend once it is known)."""
    from latdyn.version import __version__

    out = {"format": FORMAT_VERSION, "latdyn_version": __version__, "scene_hash": scene.source_hash,
           "formulation": scene.solve.formulation, "method": scene.solve.method}
    if backend is not None:
        out["backend"] = backend
    return out


# ----------------------------------------------------------------------------- encoding
def _classes() -> dict:
    from latdyn.assembly.assembler import State
    from latdyn.timeloop.progress import TransientProgress

    return {"State": State, "TransientProgress": TransientProgress}


def _encode(value, arrays: dict, path: str):
    """JSON-able form of ``value``; arrays go to ``arrays`` under a key, dataclasses by class name."""
    if isinstance(value, np.ndarray):
        key = f"a{len(arrays)}"
        arrays[key] = value
        return {"__array__": key}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        name = type(value).__name__
        if name not in _classes():
            raise TypeError(f"{path}: cannot checkpoint a {name}")
        return {"__class__": name, "fields": {f.name: _encode(getattr(value, f.name), arrays, f"{path}.{f.name}")
                                              for f in dataclasses.fields(value)}}
    if isinstance(value, dict):
        return {"__dict__": {str(k): _encode(v, arrays, f"{path}.{k}") for k, v in value.items()}}
    if isinstance(value, (list, tuple)):
        return [_encode(v, arrays, f"{path}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"{path}: cannot checkpoint a {type(value).__name__}")


def _decode(value, arrays):
    if isinstance(value, list):
        return [_decode(v, arrays) for v in value]
    if isinstance(value, dict):
        if "__array__" in value:
            return np.array(arrays[value["__array__"]])
        if "__class__" in value:
            cls = _classes()[value["__class__"]]
            return cls(**{k: _decode(v, arrays) for k, v in value["fields"].items()})
        return {k: _decode(v, arrays) for k, v in value["__dict__"].items()}
    return value


def _write(path: Path, checkpoint: Checkpoint) -> int:
    arrays: dict = {}
    document = {"identity": checkpoint.identity, "resumes": checkpoint.resumes,
                "external_work": float(checkpoint.external_work),
                "progress": _encode(checkpoint.progress, arrays, "progress"),
                "writer": _encode(checkpoint.writer, arrays, "writer"),
                "last_recorded": _encode(checkpoint.last_recorded, arrays, "last_recorded"),
                "factorization": _encode(checkpoint.factorization, arrays, "factorization")}
    arrays[_META_KEY] = np.array(json.dumps(document))
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    data = buffer.getvalue()
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    return len(data)


def _read(path: Path) -> tuple[dict, dict]:
    try:
        with np.load(path, allow_pickle=False) as f:
            arrays = {name: f[name] for name in f.files}
        document = json.loads(str(arrays.pop(_META_KEY)))
        if not isinstance(document, dict) or not isinstance(document.get("identity"), dict):
            raise ValueError("no identity")
    except (OSError, ValueError, KeyError, EOFError) as exc:
        raise CheckpointError(f"{path}: not a readable latdyn checkpoint ({type(exc).__name__}: {exc})") from exc
    return document, arrays


# ----------------------------------------------------------------------------- reading
def load(out_dir, expected: dict) -> Checkpoint:
    """The checkpoint in ``out_dir``, checked against ``expected`` (:func:`identity`).

    Raises :class:`CheckpointError` when there is none (saying so when the run in
    ``out_dir`` is already finished), when it cannot be read, or when it belongs to
    another format, package version, scene, formulation, method or backend.
    """
    folder = Path(out_dir)
    path = folder / CHECKPOINT_FILE
    if not path.is_file():
        status = None
        try:
            status = json.loads((folder / "summary.json").read_text(encoding="utf-8")).get("status")
        except (OSError, ValueError, AttributeError):
            pass
        if status == "solved":
            raise CheckpointError(f"{folder}: the run there is finished (summary.json status 'solved'); "
                                  f"there is nothing to resume")
        raise CheckpointError(f"no checkpoint in {folder} ({path} does not exist); nothing to resume")
    document, arrays = _read(path)
    found = document["identity"]
    _compare(path, found, expected)
    try:
        return Checkpoint(progress=_decode(document["progress"], arrays),
                          external_work=float(document["external_work"]),
                          writer=_decode(document["writer"], arrays),
                          last_recorded=_decode(document["last_recorded"], arrays),
                          identity=found, resumes=int(document.get("resumes", 0)),
                          factorization=_decode(document["factorization"], arrays))
    except (KeyError, TypeError, ValueError) as exc:
        raise CheckpointError(f"{path}: not a readable latdyn checkpoint ({type(exc).__name__}: {exc})") from exc


_WHAT = {"format": "checkpoint format", "latdyn_version": "package version", "scene_hash": "scene hash",
         "formulation": "solve.formulation", "method": "solve.method", "backend": "kernel backend"}


def _compare(path: Path, found: dict, expected: dict) -> None:
    for key, what in _WHAT.items():
        if key in expected and found.get(key) != expected[key]:
            hint = {"scene_hash": " (it belongs to another scene, or the scene file was edited)",
                    "backend": f" (resume with --backend {found.get(key)})",
                    "latdyn_version": " (resume with the version that wrote it, or start over)"}.get(key, "")
            raise CheckpointError(f"{path}: refused: its {what} {found.get(key)!r} differs from this run's "
                                  f"{expected[key]!r}{hint}")


def check(checkpoint: Checkpoint, out_dir, expected: dict) -> None:
    """Refuse ``checkpoint`` (:class:`CheckpointError`) where it differs from ``expected``
    (for what is known only once the model is built: the kernel backend)."""
    _compare(Path(out_dir) / CHECKPOINT_FILE, checkpoint.identity, expected)


def discard(out_dir) -> None:
    """Remove the checkpoint of ``out_dir`` (a finished run, or a fresh start)."""
    for name in (CHECKPOINT_FILE, CHECKPOINT_FILE + ".tmp"):
        try:
            (Path(out_dir) / name).unlink()
        except FileNotFoundError:
            pass


# ----------------------------------------------------------------------------- writing
class Checkpointer:
    """Writes the checkpoints of one run into ``out_dir``.

    ``interval``: wall-clock seconds between checkpoints (0: at every accepted
    step). :meth:`due` says when the next one is due; :meth:`save` first has the
    result writer put every recorded state row on disk (so the files hold at least
    what the checkpoint says was recorded), then writes the checkpoint.
    """

    def __init__(self, out_dir, interval: float, identity: dict, resumes: int = 0):
        self.path = Path(out_dir) / CHECKPOINT_FILE
        self.interval = float(interval)
        self.identity = dict(identity)
        self.resumes = int(resumes)
        self.saves = 0
        self.seconds = 0.0  # wall time spent writing checkpoints
        self.bytes = 0  # size of the last one
        self._last = time.perf_counter()
        #: writes the checkpoint of the run's last step (its time loop sets it when the steps are all taken), for
        #: an interrupt while the run's files are finished (latdyn.solve.run): ``--resume`` then finishes them
        #: without a step (fuzz7's finding 5: such a run left no checkpoint, and summary.json said interrupted)
        self.last_step = None

    def due(self) -> bool:
        return time.perf_counter() - self._last >= self.interval

    def remaining(self) -> float:
        """Seconds until the next checkpoint is due (0 when it is)."""
        return max(0.0, self.interval - (time.perf_counter() - self._last))

    def save(self, progress, external_work: float, bookmark: dict, last_recorded, writer,
             factorization: dict | None = None) -> None:
        """Write a checkpoint of ``progress`` (a TransientProgress at an accepted step) with the
        probes' ``external_work``, the writer's ``bookmark``, ``last_recorded`` and the held
        ``factorization`` of that step (see :class:`Checkpoint`); ``writer`` is the run's ResultWriter."""
        began = time.perf_counter()
        writer.checkpoint()  # state rows on disk ≥ rows in the bookmark
        self.bytes = _write(self.path, Checkpoint(progress, external_work, bookmark, last_recorded,
                                                  self.identity, self.resumes, factorization))
        end = time.perf_counter()
        self.saves += 1
        self.seconds += end - began
        self._last = end

    def discard(self) -> None:
        discard(self.path.parent)
