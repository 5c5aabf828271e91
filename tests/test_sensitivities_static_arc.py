"""Exact sensitivities of arc-length paths (latdyn/analyses/sensitivities.py, ArcLengthSensitivities;
docs/parameters.md, "Arc length").

Each row of an arc-length path is the point at the arc length Δs_n = c_n Δs₀(p) from the row before,
so its sensitivity is the derivative of that chain (the bordered solve, regular at a limit point).
Reference: central differences of whole runs at p ± h and p ± h/2 (h = 1e-4 p), Richardson-
extrapolated, row by row (the perturbed runs take the same steps, halvings and Newton counts), and
for the limit loads the differences of the limit loads the runs locate. A shallow arch clamped at
both ends, its crown pushed through a snap-through: the load factor rises to a maximum, falls to a
minimum and rises again to 1, planar and in 3D (the arch's plane tilted, its sections' principal axes
skew to that plane, so that it also moves out of its plane and its rotations turn about changing
axes)."""
from __future__ import annotations

import copy
import csv
import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, probe_columns

#: the tilt of the 3D arch's plane about x, and that plane's normal
TILT = 0.5
NORMAL = np.array([0.0, -np.sin(TILT), np.cos(TILT)])


def _arch(half: float, tilt: float, load: float, EIz: str) -> dict:
    """A circular arch of radius 1 and half-angle ``half`` (four members of two elements), clamped at
    both ends, in a plane tilted ``tilt`` about x, a load ``load``·P pushing its crown down in that
    plane; arc length, 8 steps."""
    angles = np.linspace(-half, half, 5)
    turn = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])
    points = [turn @ [np.sin(a), np.cos(a) - np.cos(half), 0.0] for a in angles]
    down = turn @ [0.0, -1.0, 0.0]
    return {
        "title": "shallow arch snapping through, arc length",
        "parameters": {"EI": 1.0, "EA0": 2.0e4, "P": 1.0},
        "sections": {"s": {"EA": "EA0", "EIy": "EI", "EIz": EIz, "GJ": 1.0, "rhoA": 0.1}},
        "bodies": {f"n{i}": {"at": [float(c) for c in p], **({"fixed": True} if i in (0, 4) else {})}
                   for i, p in enumerate(points)},
        "beams": {f"s{i}": {"from": f"n{i}", "to": f"n{i + 1}", "section": "s", "elements": 2} for i in range(4)},
        "loads": [{"at": "n2", "force": [f"({float(c * load)!r})*P" for c in down]}],
        "solve": {"analysis": "static", "method": "arc-length", "steps": 8, "sensitivities": ["EI", "EA0", "P"]},
        "output": {"probes": {"crown_y": {"point": "n2", "quantity": "position", "component": "y"},
                              "n1_x": {"point": "n1", "quantity": "displacement", "component": "x"},
                              "n1_y": {"point": "n1", "quantity": "displacement", "component": "y"},
                              "n1_z": {"point": "n1", "quantity": "displacement", "component": "z"}}}}


PLANAR = _arch(0.5, 0.0, 120.0, "1.2*EI")
SPATIAL = _arch(0.6, TILT, 200.0, "3*EI")
#: the planar arch hinged at its crown, a spring whose stiffness law and rest angle are parameters
#: (they enter the start's K₀, so the first step's length moves with them)
HINGED = copy.deepcopy(PLANAR)
HINGED["parameters"].update(k=2.0, th0=0.02)
HINGED["beams"]["s2"]["start"] = {"hinge": {"axis": [0, 0, 1], "stiffness": "k*(1 + 3*(theta - th0)**2)",
                                            "rest_angle": "th0"}}


def _run(scene: dict, names, **parameters):
    """(result, summary) of a whole run with ``parameters`` changed and ``names`` differentiated."""
    data = copy.deepcopy(scene)
    data["parameters"].update(parameters)
    data["solve"]["sensitivities"] = list(names)
    with tempfile.TemporaryDirectory(prefix="arc-") as folder:   # removed after the summary is read
        out = Path(folder)
        result = latdyn.run(latdyn.load_scene(data), out)
        return result, json.loads((out / "summary.json").read_text())


def _richardson(scene: dict, name: str) -> dict:
    """d(probe)/d(name), d(load factor)/d(name) over the rows and d(limit load)/d(name) for each limit
    point, by Richardson-extrapolated central differences of whole runs (with sensitivities, for the
    limit loads they locate; their rows are those of runs without:
    :func:`test_a_3d_arc_length_path_is_the_same_with_and_without_sensitivities`)."""
    p0 = scene["parameters"][name]
    h = 1e-4 * abs(p0)
    central = []
    for step in (h, h / 2):
        (up, up_summary), (down, down_summary) = _run(scene, [name], **{name: p0 + step}), \
            _run(scene, [name], **{name: p0 - step})
        assert len(up.t) == len(down.t)
        differences = {k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes}
        differences["load_factor"] = (up.t - down.t) / (2 * step)
        differences["limit_loads"] = np.array([
            (a["load_factor"] - b["load_factor"]) / (2 * step)
            for a, b in zip(up_summary["limit_point_sensitivities"], down_summary["limit_point_sensitivities"],
                            strict=True)])
        central.append(differences)
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


@pytest.fixture(scope="module")
def planar():
    return _run(PLANAR, ["EI", "EA0", "P"])


@pytest.fixture(scope="module")
def spatial():
    return _run(SPATIAL, ["EI", "P"])


def _limit_loads(summary: dict, name: str) -> np.ndarray:
    return np.array([point["dload_factor"][name] for point in summary["limit_point_sensitivities"]])


def _check(result, summary, reference: dict, name: str) -> None:
    for key, expected in reference.items():
        got = _limit_loads(summary, name) if key == "limit_loads" else result.sensitivities[(key, name)]
        scale = np.abs(expected).max()
        if scale == 0:   # out of a planar model's plane
            assert not np.any(got), (key, name)
            continue
        # measured ≤ 2.7e-9 (th0), 1e-10 … 1e-9 otherwise
        assert np.abs(got - expected).max() <= 3e-8 * scale, (key, name, np.abs(got - expected).max() / scale)


def _snaps_through(result, summary) -> None:
    """The path passes a maximum and a minimum of λ and ends at λ = 1: a genuine snap-through."""
    turns = np.flatnonzero(np.diff(np.sign(np.diff(result.t))))
    assert len(turns) == 2 and result.t[-1] == 1.0
    kinds = [point["kind"] for point in summary["limit_point_sensitivities"]]
    assert kinds == ["maximum", "minimum"]
    maximum, minimum = (point["load_factor"] for point in summary["limit_point_sensitivities"])
    highest, lowest = result.t[turns[0] + 1], result.t[turns[1] + 1]     # the rows at the turns
    assert highest <= maximum < highest * (1 + 1e-2) and lowest * (1 - 1e-2) < minimum <= lowest


@pytest.mark.parametrize("name", ["EI", "P"])
def test_planar_arc_length_sensitivities_through_a_snap_through_agree_with_richardson_differences(planar, name):
    """Measured: EI 9.7e-11, P 1.8e-11 of each quantity's largest (rows and limit loads; EA0, not held
    here: 3.7e-10)."""
    result, summary = planar
    _snaps_through(result, summary)
    _check(result, summary, _richardson(PLANAR, name), name)


@pytest.mark.parametrize("name", ["k", "th0"])
def test_arc_length_sensitivities_by_a_hinge_spring_agree_with_richardson_differences(name):
    """Measured: k 8.0e-11, th0 2.7e-9 of each quantity's largest (rows and limit loads)."""
    result, summary = _run(HINGED, [name])
    _snaps_through(result, summary)
    _check(result, summary, _richardson(HINGED, name), name)


def test_3d_arc_length_sensitivities_through_a_snap_through_agree_with_richardson_differences(spatial):
    """The tilted arch with sections whose stiff axis is skew to its plane: it leaves its plane (the
    rotations of a step turn about different axes). Measured 1.0e-10 (EI), limit loads 8.9e-12."""
    result, summary = spatial
    _snaps_through(result, summary)
    out_of_plane = np.column_stack([result.probes[f"n1_{c}"] for c in "xyz"]) @ NORMAL
    assert np.abs(out_of_plane).max() > 0.05 * np.abs(result.probes["n1_y"]).max()
    _check(result, summary, _richardson(SPATIAL, "EI"), "EI")


def test_a_3d_arc_length_path_is_the_same_with_and_without_sensitivities(spatial):
    """Every 3D arc-length step composes its rotation increments (latdyn/analyses/continuation.py,
    ``Path.compose``), asked for sensitivities or not, so the path differentiated is the one a run without
    them takes. Before, only the run with sensitivities composed them, and the tilted arch's load factors
    differed by up to 3.1e-5 between the two."""
    data = copy.deepcopy(SPATIAL)
    del data["solve"]["sensitivities"]
    plain = latdyn.run(latdyn.load_scene(data))
    result, _ = spatial
    assert np.array_equal(plain.t, result.t)
    for probe, values in plain.probes.items():
        assert np.array_equal(values, result.probes[probe]), probe


@pytest.mark.parametrize("scene", ["planar", "spatial"])
def test_the_limit_load_of_a_load_amplitude_is_its_inverse(scene, request):
    """r = f(q) − λ P e: the limit load λ_c P does not depend on P, so dλ_c/dP = −λ_c/P exactly (P = 1)."""
    _, summary = request.getfixturevalue(scene)
    for point in summary["limit_point_sensitivities"]:
        assert point["dload_factor"]["P"] == pytest.approx(-point["load_factor"], rel=1e-9)


def test_the_cli_writes_the_arc_length_paths_sensitivities(tmp_path, planar):
    """sensitivities.csv beside probes.csv (first column load_factor), summary.json's
    probe_sensitivities, load_factor_sensitivities and limit_point_sensitivities, as the API gives."""
    result, summary = planar
    run, out = latdyn_run(tmp_path, yaml.safe_dump(PLANAR, sort_keys=False))
    assert run.returncode == 0, run.stderr
    assert len(probe_columns(out)["load_factor"]) == len(result.t)
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0][0] == "load_factor" and "n1_y/EI" in rows[0]
    column = np.array([float(r[rows[0].index("n1_y/EI")]) for r in rows[1:]])
    assert np.allclose(column, result.sensitivities[("n1_y", "EI")], rtol=1e-12, atol=0)
    written = json.loads((out / "summary.json").read_text())
    assert written["limit_point_sensitivities"] == summary["limit_point_sensitivities"]
    peak = int(np.argmax(result.t))
    assert written["load_factor_sensitivities"]["max"]["EI"] == result.sensitivities[("load_factor", "EI")][peak]


def test_each_limit_point_is_located_once(monkeypatch):
    """The path locates each turn of λ (Path.locate_turn) and the sensitivities take its located state;
    before, the sensitivities located both of the snap-through's limit points again (4 searches)."""
    import latdyn.analyses.limit_points as limit_points

    searched = []
    locate = limit_points.locate_limit

    def counted(*args, **kwargs):
        searched.append(args[2])
        return locate(*args, **kwargs)

    monkeypatch.setattr(limit_points, "locate_limit", counted)
    _, summary = _run(PLANAR, ["EI"])
    assert len(summary["limit_point_sensitivities"]) == 2
    assert len(searched) == 2, searched
