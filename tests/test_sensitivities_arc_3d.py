"""Arc-length sensitivities, 3D and planar, against the runs a user makes (latdyn/analyses/sensitivities.py,
ArcLengthSensitivities; docs/parameters.md, "Arc length").

The reference is what a designer would check against: central differences of whole runs *without*
``solve.sensitivities``, at p ± h and p ± h/2 (h = 10⁻² p: smaller steps drown the smallest
derivatives, the load factor's by a section's EI, in the round-off of the start's Δs₀ = ‖K₀⁻¹q_ref‖_W/steps),
Richardson-extrapolated, row by row, for every probe and the load factor. A 3D arc-length step used to
sum its rotation increments unless sensitivities were asked, and compose them when they were: the run
with sensitivities then took another path than the run without (by the increments' commutators), and
its exact sensitivities were 1.5e-3 off the differences of the runs without on the gimbal below. Now
every 3D arc-length step composes them (latdyn/analyses/continuation.py, ``Path.compose``), and with
that the refusal of arc length with rigid links and guides is lifted too (their chain of rows was exact;
the 2.5e-2 measured on the rigid gimbal was the same two paths).

Scenes: the static gimbal of tests/test_sensitivities_rigid_links.py (two links on skew hinges carrying a
flexible boom, under gravity and a tip load) with its links flexible and with them rigid, and a slider on
a skew guide at the tip of a 3D arm with a beam hanging from it (tests/test_sensitivities_guides.py's),
each under arc length; and planar, a four-bar of rigid links (whose rotations commute: there the
two paths were the same, and only the rigid links' refusal is lifted)."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.numerics.so3 import compose_rotation_vectors, expm_so3
from tests.cli_runs import latdyn_run, probe_columns
from tests.test_sensitivities_guides import STATIC_GUIDE
from tests.test_sensitivities_rigid_links import FOUR_BAR, STATIC

#: the static gimbal under arc length, its spring unloaded at the start (a preloaded spring is no
#: equilibrium at λ = 0, where arc length starts), its links rigid
RIGID_GIMBAL = STATIC.replace("rest: 0.6", "rest: 0.0").replace(
    "method: load-control, steps: 4, sensitivities: [k1, m, P, EI, rest, rho]",
    "method: arc-length, steps: 4, sensitivities: [k1, m, P, EI, rho]")
#: the same with its links flexible (one stiff element each): the failing case of issue 34
GIMBAL = RIGID_GIMBAL.replace("rigid: true", "elements: 1").replace("sensitivities: [k1, m, P, EI, rho]",
                                                                   "sensitivities: [k1, m, P, EI]")
#: a slider on a skew guide at the tip of a 3D arm, a beam hanging from the slider, under gravity
GUIDED = STATIC_GUIDE.replace("method: load-control", "method: arc-length").replace(
    "sensitivities: [F, EI]", "sensitivities: [F, EI, m]").replace(
    "  arm: {from: base, to: tip, section: s, elements: 3}\n",
    "  arm: {from: base, to: tip, section: s, elements: 3}\n"
    "  hang: {from: slider, to: [0.9, 0.35, 0.7], section: s, elements: 2}\n").replace(
    "loads:\n", "gravity: [0, 0, -9.81]\nloads:\n  - {at: hang.end, force: [0, 0, \"-0.3*F\"]}\n")

#: planar: the four-bar of two rigid links and a flexible coupler, its crank's torque against its spring
PLANAR_FOUR_BAR = FOUR_BAR.replace("solve: {analysis: transient, dt: 0.01, t_end: 0.5, sensitivities: [tau, rho]}",
                                   "solve: {analysis: static, method: arc-length, steps: 4, sensitivities: [tau]}")

SCENES = {"gimbal": GIMBAL, "rigid_gimbal": RIGID_GIMBAL, "guided": GUIDED, "four_bar": PLANAR_FOUR_BAR}


def _run(text: str, sensitivities: bool = True, **parameters):
    """The Result of a whole run of ``text`` with ``parameters`` changed, with or without its
    solve.sensitivities."""
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    if not sensitivities:
        del data["solve"]["sensitivities"]
    return latdyn.run(latdyn.load_scene(data))


def _richardson(text: str, name: str) -> dict:
    """d(probe)/d(name) and d(load factor)/d(name) over the rows, by Richardson-extrapolated central
    differences of whole runs without sensitivities (module docstring)."""
    p0 = yaml.safe_load(text)["parameters"][name]
    h = 1e-2 * abs(p0)
    central = []
    for step in (h, h / 2):
        up, down = (_run(text, False, **{name: p0 + s}) for s in (step, -step))
        assert len(up.t) == len(down.t)
        differences = {k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes}
        differences["load_factor"] = (up.t - down.t) / (2 * step)
        central.append(differences)
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


@pytest.fixture(scope="module")
def runs():
    return {}


def _computed(runs: dict, scene: str):
    if scene not in runs:
        runs[scene] = _run(SCENES[scene])
    return runs[scene]


def test_a_3d_arc_length_run_takes_the_same_path_with_and_without_sensitivities(runs):
    """The rows (load factors and probes) of the flexible gimbal are the same numbers with and without
    solve.sensitivities: both compose their steps' rotations. Before, the run without summed them, and
    its load factors differed from the run with by up to 5.3e-6, its hinge angles by 1.2e-6 rad (4 steps)."""
    plain, derived = _run(GIMBAL, False), _computed(runs, "gimbal")
    assert np.array_equal(plain.t, derived.t)
    for probe, values in plain.probes.items():
        assert np.array_equal(values, derived.probes[probe]), probe


@pytest.mark.parametrize("scene, name", [
    ("gimbal", "k1"), ("gimbal", "m"), ("gimbal", "P"), ("gimbal", "EI"),
    ("rigid_gimbal", "k1"), ("rigid_gimbal", "EI"), ("rigid_gimbal", "rho"),
    ("guided", "F"), ("guided", "EI"), ("guided", "m"), ("four_bar", "tau"),
])
def test_arc_length_sensitivities_agree_with_richardson_differences_of_runs_without_them(runs, scene, name):
    """Every probe's and the load factor's sensitivity over the rows, within 1e-6 of the largest of each
    (measured: the flexible gimbal k1 5.8e-9, m 2.7e-11, P 1.3e-10, EI 1.4e-7; the rigid one k1 5.9e-9,
    EI 2.3e-8, rho 9.1e-12 (m 1.2e-11, P 4.7e-11, not run here); the guided slider F 3.8e-11, EI 8.4e-9,
    m 2.4e-11; the planar four-bar tau 9.3e-9, and by its spring k 5.4e-7, not run here: the load factor's
    derivative, 1e-3 of the crank's, is at the differences' round-off). Before: the flexible gimbal's k1
    6.4e-5, m 4.3e-5, P 6.5e-5 and EI 1.5e-3 off, the rigid gimbal, the guided slider and the four-bar
    refused (exit 2)."""
    result = _computed(runs, scene)
    assert len(result.t) >= 4 and result.t[-1] == 1.0
    for key, expected in _richardson(SCENES[scene], name).items():
        scale = np.abs(expected).max()
        assert scale > 0.0, (key, name)
        got = result.sensitivities[(key, name)]
        assert np.abs(got - expected).max() <= 1e-6 * scale, (key, name, np.abs(got - expected).max() / scale)


def test_the_cli_writes_the_rigid_gimbals_arc_length_sensitivities_as_the_api_gives_them(tmp_path, runs):
    """Through the CLI (exit 0, where arc length with rigid links exited 2 before): sensitivities.csv
    beside probes.csv, its columns the API's."""
    run, out = latdyn_run(tmp_path, RIGID_GIMBAL)
    assert run.returncode == 0, run.stderr
    result = _computed(runs, "rigid_gimbal")
    assert np.array_equal(probe_columns(out)["load_factor"], result.t)
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.reader(f))
    for column in ("a1/k1", "tip_x/EI", "outer_y/rho"):
        values = np.array([float(r[rows[0].index(column)]) for r in rows[1:]])
        assert np.allclose(values, result.sensitivities[tuple(column.split("/"))], rtol=1e-12, atol=0), column


@pytest.mark.parametrize("size", [1e-12, 1e-6, 1e-3, 0.3, 1.5, 3.0])
def test_composed_rotation_vectors_are_the_product_of_the_exponentials(size):
    """log(exp(skew a) exp(skew b)) (latdyn.numerics.so3.compose_rotation_vectors, which a 3D arc-length
    step composes its increments with): its exponential is exp(skew a) exp(skew b) to round-off and its
    angle ≤ π, from tiny angles (the series) to large ones (the product's angle past π: the shorter
    vector). Measured ≤ 2.0e-15 on the matrices; the third-order term ≤ 3.4 size³."""
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(500, 3)) * size, rng.normal(size=(500, 3)) * size
    composed = compose_rotation_vectors(a, b)
    assert np.abs(expm_so3(composed) - expm_so3(a) @ expm_so3(b)).max() <= 1e-14
    assert np.linalg.norm(composed, axis=1).max() <= np.pi + 1e-12
    if size <= 1e-3:   # small angles: a + b + (a × b)/2 to third order
        assert np.allclose(composed, a + b + 0.5 * np.cross(a, b), rtol=0, atol=10 * size ** 3 + 1e-30)
