"""Studies: one scene run many times with some keys changed (the contract is ``shared/STUDY.md``).

A study file names a scene, the keys to ``vary`` (the cartesian product of their lists
is run, one *case* per combination, in file order), a ``reference`` ("exact": the same
scene with ``reference.overrides``, run once, or a CSV table) and the ``error`` to
measure against it. :func:`study` runs every case, each into ``OUT/cases/<hash>/``
through :func:`latdyn.run`, and writes ``study.csv``, the pictures
(:mod:`latdyn.studies.plots`) and ``summary.json``.

Stages: load and validate the study (:func:`load_study`: every key, every override
applied and the resulting scene checked by :func:`latdyn.load_scene` *before* anything
runs; a problem is a :class:`~latdyn.errors.SceneError` naming the study file and key,
exit 2) → expand into cases (:func:`expand`) → run what is not cached, each case by
:func:`latdyn.studies.case.run_case` where a scheduler puts it (:mod:`latdyn.studies.cluster`:
this process, or inside a Dask worker) → measure each case's error against the reference → table,
pictures, summary.

Keys added to STUDY.md (keys may be added, none renamed):

- ``set: {PATH: value}`` — overrides applied to every case and to the reference
  (a shorter ``solve.t_end`` for a quick study, say);
- ``stability: [KEY_X, KEY_Y]`` — the two ``vary`` keys of the stability map (default:
  ``solve.dt`` across when it varies, the first other key up);
- ``peers: [NAME, ...]`` — other codes' points on the work-precision axes, read from
  ``benchmarks/peers.py`` where it exists (see :mod:`latdyn.studies.plots`).

**Modal studies** — where the scene's ``solve.analysis`` is ``modes``, ``error`` and
``reference`` may be left out (then there is no error column to fill, and ``work-precision``
cannot be drawn); each solved case adds ``spin_rate`` and ``mode_k_hz``,
``mode_k_damping_ratio``, ``mode_k_direction`` to its row from its ``summary.json``
(:func:`_modal_columns`), and ``plots: [campbell]`` (the default when one key varies) draws
them (:func:`latdyn.studies.plots.campbell`).

Override paths are dotted scene paths (``solve.dt``, ``beams.arm.elements``,
``bodies.hub.motion.rotation.angle``), with ``[i]`` for list items (``loads[0].force``).
Every part but the last must exist in the scene; the last may be a key the scene leaves
at its default (``solve.rho_inf``), and the scene loader decides whether it is a key.

**Statuses** (decided in the worker, from the run's own records):

- ``failed`` — :func:`latdyn.run` raised (a :class:`~latdyn.errors.SolverError`: Newton
  did not converge even below the minimum step; or any other error, whose message is
  kept) and the history recorded up to then is bounded by the rule below;
- ``unbounded`` — a recorded value is not finite, or the explicit method stopped on a
  non-finite residual ("became unstable"), or the run ended unbounded
  (:class:`~latdyn.errors.UnboundedError`, docs/energy.md), or the integrator *created* more energy than
  the structure ever received: with the kinetic K, strain S and potential P energies and
  the external work W (the work of loads and of the prescribed motions, SCENE.md) probed
  at every recorded time, ``created(t) = (K+S+P)(t) − (K+S+P)(0) − W(t)`` and
  ``received(t) = K(0) + S(0) + max_{s≤t}|W(s)| + max_{s≤t}|P(s) − P(0)|``, the run is
  unbounded when ``created(t) > received(t)`` at some recorded t whose ``received(t)`` passed the
  round-off of the structure at rest (the run's floor, :func:`latdyn.timeloop.progress.energy_round_off`).
  A stable run keeps
  ``created`` at its energy-balance error (10⁻³ of ``received`` and less) or below zero
  (numerical dissipation); an instability grows it exponentially past any such bound.
  The rule holds whether or not the solver later failed (an instability is what made
  Newton fail). A structure that never receives energy (``received`` ≡ 0, or within that round-off) is judged on
  non-finite values alone;
- ``solved`` — otherwise. ``t_reached`` is the last recorded time.

These four energy probes are added to every transient case as ``_study_K``, ``_study_S``,
``_study_P``, ``_study_W`` (a scene that uses one of these names is refused), except a case whose
``solve.sensitivities`` would refuse them (:func:`_with_energy_probes`): it is judged on non-finite values alone.

**Error** — over the times the case and the reference have in common (equal to 10⁻⁹ of
the time; a case recording every ``output.every`` or every step shares the reference's
grid whenever its step divides it): ``max`` = max |case − reference|, ``rms`` = the root
mean square, ``final`` = |case − reference| at the last common time. When they share fewer
than two times, the reference is interpolated linearly onto the case's times within its
range (the reference being the finer). Only ``solved`` cases have an error.

**Timing** — ``wall_s`` is the median over ``repeats`` runs of the time :func:`latdyn.run`
took (building the model, the time loop and writing the case's files), less
``compile_s`` where ``summary.json`` reports one. Compilation and first-use costs are
kept out by a warm-up: in each process, before the first timed run of a formulation, a
run of the same case cut to two steps. A case that fails is run once.

**Cache** — a case's folder is named by the first 16 hex digits of the hash of its
whole scene after the overrides (so a changed scene file never reuses stale cases); its
``case.json``, written last and atomically, makes it finished. A rerun of the study
reuses every finished case with at least ``repeats`` timings and runs only the rest.
The key is the scene, not the code: after changing latdyn itself, study into a new
folder (or delete ``cases/``) to rerun everything.
"""
from __future__ import annotations

import contextlib
import copy
import csv
import itertools
import json
import math
import os
import platform
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from latdyn.errors import SceneError, show_value
from latdyn.studies.case import (
    CASE_FILE,
    ENERGY_PROBES,
    STATUSES,
    _write_json,
    cached_record,
    run_case,
)

__all__ = ["StudySpec", "Case", "StudyTable", "load_study", "expand", "study", "run_case", "case_error",
           "COLUMNS", "STATUSES", "NORMS", "PLOTS", "CASE_FILE"]

NORMS = ("max", "rms", "final")
PLOTS = ("work-precision", "stability", "campbell")
#: The columns of study.csv after the ``vary`` keys (STUDY.md), then the added ones.
COLUMNS = ("status", "error", "wall_s", "steps", "newton_iterations", "rejected_steps", "coordinates")
EXTRA_COLUMNS = ("t_reached", "case", "message")
TIMING_COLUMNS = ("wall_s",)
_TOP_KEYS = ("title", "scene", "vary", "reference", "error", "repeats", "plots", "set", "stability", "peers")
_INDEX = re.compile(r"^(?P<name>[^\[\]]+)(?P<index>(\[\d+\])*)$")


# =========================================================================== the study file
@dataclass
class StudySpec:
    """A validated study: the scene as a mapping (after ``set``), what varies, and how to judge."""
    file: str
    title: str
    scene_file: str
    base: dict                              # the scene's mapping, ``set`` applied
    vary: dict                              # key path -> list of values, in file order
    probe: str | None                       # None: a modal study without error
    norm: str = "max"
    reference_overrides: dict | None = None
    reference_file: str | None = None
    repeats: int = 1
    plots: tuple = PLOTS
    stability: tuple | None = None
    peers: tuple = ()
    set: dict = field(default_factory=dict)

    @property
    def modal(self) -> bool:
        """The scene's ``solve.analysis`` is ``modes``: each case adds its frequencies to the table."""
        return (self.base.get("solve") or {}).get("analysis") == "modes"

    @property
    def numeric_keys(self) -> list[str]:
        """Vary keys whose values are all numbers (not booleans)."""
        return [k for k, vs in self.vary.items() if all(_is_number(v) for v in vs)]


@dataclass
class Case:
    """One combination of the ``vary`` values: its overrides, its scene and the hash naming its folder."""
    index: int
    overrides: dict
    raw: dict
    hash: str


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _fail(file: str, key: str, expected: str, got: Any = None):
    if got is not None:
        expected = f"{expected}, got {show_value(got)}"
    raise SceneError(file, key, expected)


def _split_path(path: str) -> list:
    """``loads[0].force`` -> ``["loads", 0, "force"]``; None when malformed."""
    if not isinstance(path, str) or not path or path != path.strip():
        return None
    parts: list = []
    for segment in path.split("."):
        m = _INDEX.match(segment)
        if not m:
            return None
        parts.append(m["name"])
        parts.extend(int(i) for i in re.findall(r"\[(\d+)\]", m["index"]))
    return parts


def apply_override(raw: dict, path: str, value, file: str, key: str) -> None:
    """Set the dotted scene ``path`` of ``raw`` (a scene mapping) to ``value``, in place.

    Every part but the last must exist; a missing one is a SceneError naming the study
    ``file`` and ``key`` and listing what the scene has there.
    """
    parts = _split_path(path)
    if not parts:
        _fail(file, key, "expected a dotted scene path (solve.dt, beams.NAME.elements, loads[0].force)", path)
    node = raw
    for depth, part in enumerate(parts[:-1]):
        where = ".".join(str(p) for p in parts[:depth]) or "the scene"
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                _fail(file, key, f"the scene has no item [{part}] in {where}")
            node = node[part]
            continue
        if not isinstance(node, dict) or part not in node:
            known = ", ".join(map(str, node)) if isinstance(node, dict) and node else "none"
            _fail(file, key, f"the scene has no {part!r} in {where} (it has: {known}); "
                             "expected a path that exists in the scene")
        node = node[part]
    last = parts[-1]
    parent = ".".join(str(p) for p in parts[:-1])
    if isinstance(last, int):
        if not isinstance(node, list) or last >= len(node):
            _fail(file, key, f"the scene has no item [{last}] in {parent}")
        node[last] = copy.deepcopy(value)
    else:
        if not isinstance(node, dict):
            _fail(file, key, f"the scene's {parent} is not a mapping of keys, so it has no {last!r}")
        node[last] = copy.deepcopy(value)


def _read_yaml(path: Path, file: str):
    import yaml

    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        _fail(file, "(file)", "no such study file")
    except (OSError, UnicodeDecodeError) as exc:
        _fail(file, "(file)", f"unreadable study file ({exc})")
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        _fail(file, "(file)", f"expected a YAML mapping of study keys; the YAML does not parse ({exc})")


def _check_scene(raw: dict, file: str, key: str, what: str, path: str | None = None, path_key: str | None = None):
    """Validate a case's scene: a SceneError names the study key and then the scene's own complaint
    (``path_key`` instead of ``key`` when the scene refuses ``path`` itself as an unknown key)."""
    from latdyn.scene.loader import load_scene

    try:
        return load_scene(raw)
    except SceneError as exc:
        if path is not None and exc.key == path and "unknown key" in exc.expected:
            raise SceneError(file, path_key, f"not a key of the scene: {exc.expected}") from None
        raise SceneError(file, key, f"{what} gives an invalid scene: {exc.key}: {exc.expected}") from None


def _apply_all(raw: dict, overrides: dict, file: str, block: str):
    """Apply a block of overrides (``set``, ``reference.overrides``) to ``raw`` in place and
    validate the result once; an error names the override the scene complains about."""
    from latdyn.scene.loader import load_scene

    for path, value in overrides.items():
        apply_override(raw, path, value, file, f"{block}.{path}")
    try:
        return load_scene(raw)
    except SceneError as exc:
        key = f"{block}.{exc.key}" if exc.key in overrides else block
        if exc.key in overrides and "unknown key" in exc.expected:
            raise SceneError(file, key, f"not a key of the scene: {exc.expected}") from None
        raise SceneError(file, key, f"the scene with these overrides is invalid: {exc.key}: {exc.expected}") from None


def load_study(source, base_dir=None) -> StudySpec:
    """Read and validate a study (a path to YAML/JSON or a mapping), nothing run.

    A mapping's relative paths (``scene``, ``reference.file``) are taken from
    ``base_dir`` (default: the current directory). Raises SceneError naming the study
    file, the key (``vary.solve.dt``) and what was expected.
    """
    if isinstance(source, dict):
        file, raw = "<study>", copy.deepcopy(source)
        base = Path(base_dir) if base_dir is not None else Path.cwd()
    elif isinstance(source, (str, os.PathLike)):
        file = os.fspath(source)
        raw = _read_yaml(Path(file), file)
        base = Path(file).resolve().parent
    else:
        raise SceneError("<study>", "(source)", f"expected a path to a study file or a mapping, got {show_value(source)}")
    if not isinstance(raw, dict):
        _fail(file, "(top level)", f"expected a mapping of study keys ({', '.join(_TOP_KEYS)})", raw)
    for key in raw:
        if key not in _TOP_KEYS:
            _fail(file, str(key), f"unknown key; expected one of {', '.join(_TOP_KEYS)}")
    for key in ("scene", "vary"):
        if key not in raw:
            _fail(file, key, f"missing required key {key!r}")

    title = raw.get("title") or ""
    if not isinstance(title, str):
        _fail(file, "title", "expected free text", title)
    scene_rel = raw["scene"]
    if not isinstance(scene_rel, str) or not scene_rel.strip():
        _fail(file, "scene", "expected the path of a scene file, relative to the study file", scene_rel)
    scene_path = (base / scene_rel)
    if not scene_path.is_file():
        _fail(file, "scene", f"no such scene file {str(scene_path)!r}")
    from latdyn.scene.loader import load_scene

    try:
        scene = load_scene(str(scene_path))  # the scene's own errors, naming its file
    except SceneError as exc:
        raise SceneError(file, "scene", f"the scene is invalid: {exc}") from None
    base_raw = copy.deepcopy(scene.raw)

    overrides_set = raw.get("set") or {}
    if not isinstance(overrides_set, dict):
        _fail(file, "set", "expected a mapping of scene paths to values", overrides_set)
    scene = _apply_all(base_raw, overrides_set, file, "set")

    vary = raw["vary"]
    if not isinstance(vary, dict) or not vary:
        _fail(file, "vary", "expected a mapping of scene paths to lists of values", vary)
    for path, values in vary.items():
        key = f"vary.{path}"
        if not isinstance(values, list) or not values:
            _fail(file, key, "expected a non-empty list of values", values)
        _check_parameter_path(scene, path, file, key)
        for i, value in enumerate(values):
            if not isinstance(value, (str, int, float, bool)) and not (isinstance(value, (list, dict))):
                _fail(file, f"{key}[{i}]", "expected a number, a string, a boolean, a list or a mapping", value)
            trial = copy.deepcopy(base_raw)
            apply_override(trial, path, value, file, key)
            _check_scene(trial, file, f"{key}[{i}]", f"value {show_value(value)}", path, key)
        seen = [json.dumps(v, sort_keys=True, default=str) for v in values]
        if len(set(seen)) != len(seen):
            _fail(file, key, "expected each value once", values)

    modal = scene.solve.analysis == "modes"
    probes = [p.name for p in scene.output.probes]
    for name in probes:
        if name in ENERGY_PROBES:
            _fail(file, "scene", f"the probe name {name!r} is reserved for the study's energy probes")
    if "error" not in raw and not modal:
        _fail(file, "error", "missing required key 'error' (a study of a modes scene may leave it out)")
    if modal and "error" not in raw:
        if "reference" in raw:
            _fail(file, "reference", "a reference needs error: {probe: NAME}; a modal study tabulates its "
                                     "frequencies without either")
        probe, norm, reference = None, "max", None
    else:
        error = raw["error"]
        if not isinstance(error, dict):
            _fail(file, "error", "expected a mapping {probe: NAME, norm: max|rms|final}", error)
        for key in error:
            if key not in ("probe", "norm"):
                _fail(file, f"error.{key}", "unknown key; expected probe or norm")
        probe = error.get("probe")
        if probe not in probes:
            _fail(file, "error.probe", f"expected a probe of the scene ({', '.join(probes) or 'it has none'})", probe)
        norm = error.get("norm", "max")
        if norm not in NORMS:
            _fail(file, "error.norm", f"expected one of {', '.join(NORMS)}", norm)
        reference = raw.get("reference")
        if reference is None:
            _fail(file, "reference", "missing required key 'reference' (overrides: {...} or file: TABLE.csv)")

    ref_overrides, ref_file = None, None
    if reference is None:  # a modal study without error: nothing to compare with
        pass
    elif not isinstance(reference, dict) or len(reference) != 1 or next(iter(reference)) not in ("overrides", "file"):
        _fail(file, "reference", "expected exactly one of overrides: {PATH: value} or file: TABLE.csv", reference)
    elif "overrides" in reference:
        ref_overrides = reference["overrides"] or {}
        if not isinstance(ref_overrides, dict):
            _fail(file, "reference.overrides", "expected a mapping of scene paths to values", ref_overrides)
        _apply_all(copy.deepcopy(base_raw), ref_overrides, file, "reference.overrides")
    else:
        ref_rel = reference["file"]
        if not isinstance(ref_rel, str):
            _fail(file, "reference.file", "expected the path of a CSV table, relative to the study file", ref_rel)
        ref_path = base / ref_rel
        if not ref_path.is_file():
            _fail(file, "reference.file", f"no such table {str(ref_path)!r}")
        header = _csv_header(ref_path)
        if "t" not in header or probe not in header:
            _fail(file, "reference.file", f"expected a table with columns t and {probe}", header)
        ref_file = str(ref_path)

    repeats = raw.get("repeats", 1)
    if not isinstance(repeats, int) or isinstance(repeats, bool) or not 1 <= repeats <= 100:
        _fail(file, "repeats", "expected a whole number of runs from 1 to 100", repeats)
    plots = raw.get("plots", default_plots(modal, vary, probe))
    if not isinstance(plots, list) or any(p not in PLOTS for p in plots):
        _fail(file, "plots", f"expected a list of {', '.join(PLOTS)}", plots)
    if "work-precision" in plots and probe is None:
        _fail(file, "plots", "work-precision needs error: {probe: NAME} and a reference", plots)
    if "campbell" in plots and not modal:
        _fail(file, "plots", "campbell needs a scene whose solve.analysis is modes", plots)
    if "campbell" in plots and len(vary) != 1:
        _fail(file, "plots", f"campbell draws frequency against one vary key; {len(vary)} vary", plots)
    stability = raw.get("stability")
    if stability is not None:
        if (not isinstance(stability, list) or len(stability) != 2 or len(set(map(str, stability))) != 2
                or any(k not in vary for k in stability)):
            _fail(file, "stability", f"expected two different vary keys ({', '.join(vary)})", stability)
        stability = tuple(stability)
    peers = raw.get("peers") or []
    if not isinstance(peers, list) or not all(isinstance(p, str) for p in peers):
        _fail(file, "peers", "expected a list of peer names (e.g. [exudyn])", peers)

    spec = StudySpec(file=file, title=title or scene.title, scene_file=str(scene_path), base=base_raw,
                     vary=dict(vary), probe=probe, norm=norm, reference_overrides=ref_overrides,
                     reference_file=ref_file, repeats=repeats, plots=tuple(plots), stability=stability,
                     peers=tuple(peers), set=dict(overrides_set))
    expand(spec)  # every combination checked too (dt > t_end and the like)
    return spec


def default_plots(modal: bool, vary: dict, probe: str | None) -> list[str]:
    """The pictures drawn when the study names none: a modal study varying one key gets its
    Campbell diagram; a study with an error gets work-precision and stability (the latter
    only drawn where two keys vary)."""
    if modal and probe is None:
        return ["campbell"] if isinstance(vary, dict) and len(vary) == 1 else ["stability"]
    return ["work-precision", "stability"] + (["campbell"] if modal and len(vary) == 1 else [])


def _csv_header(path: Path) -> list[str]:
    with open(path, newline="", encoding="utf-8") as f:
        return next(csv.reader(f), [])


# =========================================================================== cases
def _with_energy_probes(raw: dict, scene) -> dict:
    """The case scene with :data:`ENERGY_PROBES` added (transient analyses only), except where the scene's
    ``solve.sensitivities`` would refuse them (an energy probe is differentiated with the scene's own probes, and
    some are not: with cables, controllers, an adaptive run's loads in t —
    latdyn/analyses/energy_sensitivities.py): the case is then judged on non-finite values alone, as a structure
    that never receives energy, rather than refused for a probe its author never wrote. ``scene``: ``raw`` loaded."""
    solve = raw.get("solve") or {}
    if solve.get("analysis", "transient") != "transient":
        return raw
    if solve.get("sensitivities") and _energies_refuse_the_sensitivities(raw, scene):
        return raw
    return _add_energy_probes(raw)


def _energies_refuse_the_sensitivities(raw: dict, scene) -> bool:
    """Whether adding :data:`ENERGY_PROBES` to ``raw`` (``scene`` loaded) makes its ``solve.sensitivities``
    refused where without them it is not (latdyn/analyses/sensitivities.py ``refusal``: the same check the run
    makes first)."""
    from latdyn.analyses.sensitivities import refusal
    from latdyn.scene.loader import load_scene

    try:
        if refusal(scene) is not None:
            return False   # refused for the scene's own reasons: the case's run reports those
        return refusal(load_scene(_add_energy_probes(copy.deepcopy(raw)))) is not None
    except SceneError:
        return False   # a scene that does not load: the case's run reports it


def _add_energy_probes(raw: dict) -> dict:
    """``raw`` with :data:`ENERGY_PROBES` added to its probes (a list or a mapping)."""
    if raw.get("output") is None:
        raw["output"] = {}
    output = raw["output"]
    probes = output.get("probes")
    if probes is None:
        probes = output["probes"] = {}
    if isinstance(probes, list):
        probes.extend({"name": name, "energy": kind} for name, kind in ENERGY_PROBES.items())
    else:
        probes.update({name: {"energy": kind} for name, kind in ENERGY_PROBES.items()})
    return raw


def _check_parameter_path(scene, path: str, file: str, key: str) -> None:
    """A ``vary`` path ``parameters.NAME`` names a parameter the scene has (a new name would be a
    parameter that nothing uses, and the study would vary nothing)."""
    if path.startswith("parameters.") and path[len("parameters."):] not in scene.parameters.values:
        known = ", ".join(scene.parameters.values) or "none"
        _fail(file, key, f"expected parameters.NAME of a parameter of the scene (parameters: {known})", path)


def _case_scene(spec: StudySpec, overrides: dict, key: str):
    raw = copy.deepcopy(spec.base)
    for path, value in overrides.items():
        apply_override(raw, path, value, spec.file, key)
    what = "the combination " + ", ".join(f"{k} = {show_value(v)}" for k, v in overrides.items())
    plain = _check_scene(raw, spec.file, key, what)
    raw = _with_energy_probes(raw, plain)
    scene = _check_scene(raw, spec.file, key, what)
    return raw, scene.source_hash[:16]


def expand(spec: StudySpec) -> list[Case]:
    """The cases of the study, in the order of the cartesian product of ``vary`` (file order)."""
    keys = list(spec.vary)
    cases = []
    for index, values in enumerate(itertools.product(*(spec.vary[k] for k in keys))):
        overrides = dict(zip(keys, values))
        raw, digest = _case_scene(spec, overrides, "vary")
        cases.append(Case(index, overrides, raw, digest))
    return cases


def reference_case(spec: StudySpec) -> Case | None:
    """The reference run (the scene with ``reference.overrides``), or None for a table."""
    if spec.reference_overrides is None:
        return None
    raw, digest = _case_scene(spec, dict(spec.reference_overrides), "reference.overrides")
    return Case(-1, dict(spec.reference_overrides), raw, digest)


# =========================================================================== errors
def _load_table(path) -> tuple[np.ndarray, dict]:
    from latdyn.results.result import Result

    if Path(path).is_dir():
        result = Result.load(path)
        return result.t, result.probes
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], [r for r in rows[1:] if r]
    data = np.array([[float(x) for x in r] for r in body], dtype=float).reshape(len(body), len(header))
    return data[:, header.index("t")], {name: data[:, j] for j, name in enumerate(header) if name != "t"}


def case_error(t, values, t_ref, v_ref, norm: str) -> float:
    """The error of a case's probe against the reference (see the module docstring)."""
    t, values = np.asarray(t, float), np.asarray(values, float)
    t_ref, v_ref = np.asarray(t_ref, float), np.asarray(v_ref, float)
    if len(t) == 0 or len(t_ref) == 0:
        return math.nan
    j = np.clip(np.searchsorted(t_ref, t), 0, len(t_ref) - 1)
    jl = np.clip(j - 1, 0, len(t_ref) - 1)
    nearest = np.where(np.abs(t_ref[jl] - t) < np.abs(t_ref[j] - t), jl, j)
    common = np.abs(t_ref[nearest] - t) <= 1e-9 * np.maximum(1.0, np.abs(t))
    if common.sum() >= 2:
        difference = values[common] - v_ref[nearest[common]]
    else:
        inside = (t >= t_ref[0]) & (t <= t_ref[-1])
        if not inside.any():
            return math.nan
        difference = values[inside] - np.interp(t[inside], t_ref, v_ref)
    if norm == "max":
        return float(np.max(np.abs(difference)))
    if norm == "rms":
        return float(np.sqrt(np.mean(difference ** 2)))
    return float(abs(difference[-1]))


# =========================================================================== modal cases
#: What a modal case's ``summary.json`` gives each mode k of ``study.csv``: column name -> summary key.
MODE_COLUMNS = {"mode_{k}_hz": "modes_hz", "mode_{k}_damping_ratio": "damping_ratios",
                "mode_{k}_direction": "mode_directions"}


def _modal_columns(rows: list[dict], out: Path) -> list[str]:
    """Add each solved modal case's frequencies to its row (in place) and return the new
    columns: ``spin_rate`` (rad/s, the rate of the frame the modes are seen in: the steady
    spin of ``solve.about: steady``) when some case spins, then ``mode_k_hz``,
    ``mode_k_damping_ratio``, ``mode_k_direction`` for k = 1 … the most modes a case found
    (in the order of the case's ``modes.csv``: by natural frequency)."""
    count, spins = 0, False
    for row in rows:
        summary = {}
        if row["status"] == "solved":
            with contextlib.suppress(OSError, ValueError):
                summary = json.loads((out / "cases" / row["case"] / "summary.json").read_text(encoding="utf-8"))
        row["spin_rate"] = summary.get("spin_rate")
        spins = spins or bool(row["spin_rate"])
        for column, key in MODE_COLUMNS.items():
            for k, value in enumerate(summary.get(key) or [], start=1):
                row[column.format(k=k)] = value
        count = max(count, len(summary.get("modes_hz") or []))
    columns = ["spin_rate"] if spins else []
    for k in range(1, count + 1):
        columns += [column.format(k=k) for column in MODE_COLUMNS]
    return columns


# =========================================================================== the table
class StudyTable:
    """The rows of ``study.csv``: ``columns`` (vary keys, then :data:`COLUMNS`, then
    ``t_reached``, ``case``, ``message``) and ``rows`` (dicts); ``table["solve.dt"]`` is a
    column as a list. ``out_dir`` and ``summary`` say where it was written and how."""

    def __init__(self, columns, rows, out_dir=None, summary=None):
        self.columns = list(columns)
        self.rows = [dict(r) for r in rows]
        self.out_dir = None if out_dir is None else str(out_dir)
        self.summary = dict(summary or {})

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self):
        return iter(self.rows)

    def __getitem__(self, column: str) -> list:
        if column not in self.columns:
            raise KeyError(f"no column {column!r} (columns: {', '.join(self.columns)})")
        return [r.get(column) for r in self.rows]

    def __repr__(self) -> str:
        counts = {s: sum(r["status"] == s for r in self.rows) for s in STATUSES}
        return f"StudyTable({len(self.rows)} cases, {counts}, out_dir={self.out_dir!r})"

    def to_csv(self, path) -> None:
        with open(path, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f, lineterminator="\n")
            writer.writerow(self.columns)
            for row in self.rows:
                writer.writerow([_cell(row.get(c)) for c in self.columns])

    @classmethod
    def read_csv(cls, path) -> "StudyTable":
        """Read a study.csv back (numbers as floats, empty cells as None)."""
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        header = rows[0]
        return cls(header, [{c: _parse_cell(x) for c, x in zip(header, r)} for r in rows[1:]], Path(path).parent)


def _cell(value) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, dict)):
        return json.dumps(value)
    return str(value)


def _parse_cell(text: str):
    if text == "":
        return None
    try:
        number = float(text)
    except ValueError:
        return text
    return int(number) if re.fullmatch(r"-?\d+", text) else number


# =========================================================================== the study
class _Progress:
    """``study: 3/13 runs (2 reused), 14 s elapsed, about 40 s left`` on stderr (the runs are
    the cases and the reference)."""

    def __init__(self, total: int, cached: int, enabled: bool):
        self.total, self.cached, self.done, self.enabled = total, cached, cached, enabled
        self.start = time.perf_counter()
        try:
            self.tty = sys.stderr.isatty()
        except (AttributeError, ValueError):
            self.tty = False

    def update(self, label: str = "") -> None:
        self.done += 1
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        ran = self.done - self.cached
        left = self.total - self.done
        estimate = f", about {_seconds(elapsed / ran * left)} left" if ran and left else ""
        cached = f" ({self.cached} reused)" if self.cached else ""
        line = f"study: {self.done}/{self.total} runs{cached}, {_seconds(elapsed)} elapsed{estimate}"
        if label:
            line += f"  [{label}]"
        end = "\r" if self.tty and left else "\n"
        print(f"{line:<100}" if self.tty else line, end=end, file=sys.stderr, flush=True)


def _seconds(s: float) -> str:
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


def _label(overrides: dict) -> str:
    return ", ".join(f"{k.rsplit('.', 1)[-1]}={v}" for k, v in overrides.items())


def _machine() -> dict:
    cpu = platform.processor() or ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    return {"cores": os.cpu_count(), "cpu": cpu, "platform": platform.platform(), "hostname": platform.node()}


def _versions() -> dict:
    from importlib import metadata

    from latdyn.version import __version__

    versions = {"latdyn": __version__, "python": platform.python_version()}
    for name in ("numpy", "scipy", "matplotlib", "dask", "distributed", "threadpoolctl"):
        with contextlib.suppress(metadata.PackageNotFoundError):
            versions[name] = metadata.version(name)
    return versions


def default_out_dir(study_path) -> Path:
    """``<study stem>_study`` in the current directory (STUDY.md)."""
    return Path.cwd() / f"{Path(study_path).stem}_study"


def study(source, scheduler: str | None = None, out=None, *, client=None, progress: bool = True,
          backend: str = "auto", plots: bool = True) -> StudyTable:
    """Run a study (a path to its YAML file or a mapping); returns the :class:`StudyTable`.

    ``scheduler``: ``"serial"`` (this process, the default), ``"local"``/``"local:N"`` (a
    Dask LocalCluster of N worker processes, default the cores) or the address of a
    running Dask scheduler. ``client``: instead, a ``dask.distributed.Client`` the caller
    made (on a ``LocalCluster``, a ``dask_jobqueue.SLURMCluster`` …); it is used and left
    open. Dask workers must see ``out`` at the same path (a shared file system). ``out``:
    the folder (default ``<study stem>_study``; required for a mapping). Raises SceneError
    before anything runs when the study is invalid, and ValueError for a malformed
    ``scheduler``, a ``client`` that is not one, or both given.
    """
    from latdyn.studies import cluster as study_dask

    wall0 = time.perf_counter()
    spec = load_study(source)
    if client is not None:  # ValueError before anything runs
        if scheduler is not None:
            raise ValueError("give either scheduler= or client=, not both")
        study_dask.open_client(client)
        kind = ("client", client)
    else:
        kind = study_dask.parse_scheduler("serial" if scheduler is None else scheduler)
    if out is None:
        if isinstance(source, dict):
            raise ValueError("a study given as a mapping needs an output folder (out=...)")
        out = default_out_dir(source)
    out = Path(out)
    cases = expand(spec)
    ref = reference_case(spec)
    (out / "cases").mkdir(parents=True, exist_ok=True)

    everything = ([ref] if ref is not None else []) + cases
    unique = {}
    for case in everything:
        unique.setdefault(case.hash, case)
    records, todo = {}, []
    for digest, case in unique.items():
        repeats = 1 if case is ref else spec.repeats
        record = cached_record(out / "cases" / digest, digest, repeats)
        if record is not None:
            records[digest] = record
        else:
            todo.append({"raw": case.raw, "dir": os.path.abspath(out / "cases" / digest), "repeats": repeats,
                         "hash": digest, "overrides": case.overrides, "backend": backend,
                         "scene_file": spec.scene_file,
                         "label": "reference" if case is ref else _label(case.overrides)})
    bar = _Progress(len(unique), len(records), progress)
    if progress and records:
        print(f"study: {len(records)} of {len(unique)} runs reused from {out / 'cases'}", file=sys.stderr)
    with study_dask.open_scheduler(kind) as runner:
        for task, record in runner.run(run_case, todo):
            records[task["hash"]] = record
            bar.update(task["label"])

    # the error of each case against the reference
    reference_info: dict = {}
    t_ref = v_ref = None
    if ref is not None:
        rec = records[ref.hash]
        reference_info = {"overrides": ref.overrides, "case": ref.hash, "status": rec["status"],
                          "wall_s": rec.get("wall_s"), "message": rec.get("message", "")}
        if rec["status"] == "solved":
            t_ref, probes = _load_table(out / "cases" / ref.hash)
            v_ref = probes[spec.probe]
        elif progress:
            print(f"study: the reference run is {rec['status']} ({rec.get('message', '')}); no errors",
                  file=sys.stderr)
    elif spec.reference_file is not None:
        reference_info = {"file": spec.reference_file}
        t_ref, probes = _load_table(spec.reference_file)
        v_ref = probes[spec.probe]

    keys = list(spec.vary)
    rows = []
    for case in cases:
        rec = records[case.hash]
        error = math.nan
        if rec["status"] == "solved" and t_ref is not None:
            t, probes = _load_table(out / "cases" / case.hash)
            error = case_error(t, probes[spec.probe], t_ref, v_ref, spec.norm)
        row = dict(case.overrides)
        row.update(status=rec["status"], error=error, wall_s=rec.get("wall_s"), steps=rec.get("steps"),
                   newton_iterations=rec.get("newton_iterations"), rejected_steps=rec.get("rejected_steps"),
                   coordinates=rec.get("coordinates"), t_reached=rec.get("t_reached"), case=case.hash,
                   message=rec.get("message", ""))
        rows.append(row)
    mode_columns = _modal_columns(rows, out) if spec.modal else []
    table = StudyTable(keys + list(COLUMNS) + list(EXTRA_COLUMNS) + mode_columns, rows, out_dir=out)
    table.to_csv(out / "study.csv")

    pictures, orders = [], []
    if plots:
        from latdyn.studies import plots as study_plots

        pictures, orders = study_plots.draw(table, spec, out)
    counts = {s: sum(r["status"] == s for r in rows) for s in STATUSES}
    summary = {
        "title": spec.title, "study_file": spec.file, "scene": spec.scene_file, "vary": spec.vary,
        "set": spec.set,
        "error": None if spec.probe is None else {"probe": spec.probe, "norm": spec.norm}, "repeats": spec.repeats,
        "reference": reference_info, "cases": len(cases), "ran": len(todo), "reused": len(unique) - len(todo),
        "statuses": counts, "orders": orders, "pictures": [p.name for p in pictures],
        "scheduler": runner.describe(), "machine": _machine(), "versions": _versions(),
        "wall_time_s": time.perf_counter() - wall0,
    }
    _write_json(out / "summary.json", summary)
    table.summary = summary
    if progress:
        print(f"study: {len(cases)} cases ({counts['solved']} solved, {counts['failed']} failed, "
              f"{counts['unbounded']} unbounded) in {_seconds(summary['wall_time_s'])} -> {out}", file=sys.stderr)
    return table
