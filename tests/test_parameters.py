"""Named parameters (SCENE.md, "Parameters and sensitivities"; latdyn/scene/parameters.py).

A scene written with parameters is the scene written with their values: loaded, the numbers are
the same to the last bit, and run through the CLI and the API, the probes are the same, planar and
genuinely 3D. What depends on which parameter is recorded, and its derivative agrees with central
differences of the scene loaded at perturbed values. Bad names and unknown names are refused
naming the key path."""
from __future__ import annotations

import os
import pickle
import subprocess
import sys

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.scene.builder import SceneBuilder, hinge
from latdyn.scene.loader import load_scene
from latdyn.scene.parameters import RESERVED
from tests.cli_runs import ROOT, latdyn_run, probe_columns

# A genuinely 3D scene: a hinged, tilted beam with a tip body, an axis out of every coordinate
# plane, a hinge law in theta, a load turning in time and an initial spin; every number that a
# user would tune is a parameter.
SPATIAL_WITH_PARAMETERS = """
title: tilted hinged arm, parameters
parameters: {E: 7.0e10, I: 2.0e-9, rho: 2700.0, A: 3.0e-5, L: 0.8, m: 0.05, k: 3.0, theta0: 0.05,
             F: 0.4, w: 0.7, n: 3}
gravity: [0, 0, "-9.81*0.1"]
initial_velocity: {angular: [0, 0, "w"]}
sections:
  tube: {EA: "E*A", EIy: "E*I", EIz: "1.3*E*I", GJ: "0.8*E*I", rhoA: "rho*A", rhoIy: "rho*I", rhoIz: "rho*I"}
bodies:
  base: {at: [0, 0, 0], mass: 1.0, inertia: ["0.01", 0.02, 0.03]}
  tip: {at: ["L", "0.3*L", "0.2*L"], mass: "m", inertia: ["m*1e-4", "m*1e-4", "m*2e-4"]}
beams:
  arm:
    from: base
    to: tip
    section: tube
    elements: "n"
    start: {hinge: {axis: [0.2, "-0.1", 1], stiffness: "k*(1 + 2*(theta - theta0)**2)", damping: "0.01*k"}}
loads:
  - {at: tip, force: ["F*sin(5*t)", 0, "F*0.5"], moment: [0, "0.01*F", 0]}
solve: {analysis: transient, t_end: 0.03, dt: "0.01"}
output:
  probes:
    tip_z: {point: tip, quantity: position, component: z}
    tip_vy: {point: tip, quantity: velocity, component: y}
    hinge: {hinge: arm.start, quantity: angle}
"""

SPATIAL_WITH_NUMBERS = """
title: tilted hinged arm, numbers
gravity: [0, 0, -0.981]
initial_velocity: {angular: [0, 0, 0.7]}
sections:
  tube: {EA: 2.1e6, EIy: 140.0, EIz: 182.0, GJ: 112.0, rhoA: 0.081, rhoIy: 5.4e-6, rhoIz: 5.4e-6}
bodies:
  base: {at: [0, 0, 0], mass: 1.0, inertia: [0.01, 0.02, 0.03]}
  tip: {at: [0.8, 0.24, 0.16], mass: 0.05, inertia: [5.0e-6, 5.0e-6, 1.0e-5]}
beams:
  arm:
    from: base
    to: tip
    section: tube
    elements: 3
    start: {hinge: {axis: [0.2, -0.1, 1], stiffness: "3.0*(1 + 2*(theta - 0.05)**2)", damping: 0.03}}
loads:
  - {at: tip, force: ["0.4*sin(5*t)", 0, 0.2], moment: [0, 0.004, 0]}
solve: {analysis: transient, t_end: 0.03, dt: 0.01}
output:
  probes:
    tip_z: {point: tip, quantity: position, component: z}
    tip_vy: {point: tip, quantity: velocity, component: y}
    hinge: {hinge: arm.start, quantity: angle}
"""

PLANAR = """
title: planar pendulum arm
parameters: {L: 1.2, k: 5.0, c: 0.02, P: 0.3}
sections:
  s: {EA: 1.0e6, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  arm:
    from: base
    to: ["L", 0, 0]
    section: s
    elements: 2
    start: {hinge: {axis: [0, 0, 1], stiffness: "k", damping: "c", torque: "P*cos(3*t)"}}
solve: {t_end: 0.03, dt: 0.01}
output:
  probes:
    tip_y: {point: arm.end, quantity: position, component: y}
"""


def _numbers(text: str) -> str:
    """PLANAR with its parameters written as numbers."""
    data = yaml.safe_load(text)
    del data["parameters"]
    data["beams"]["arm"]["to"] = [1.2, 0, 0]
    data["beams"]["arm"]["start"] = {"hinge": {"axis": [0, 0, 1], "stiffness": 5.0, "damping": 0.02,
                                               "torque": "0.3*cos(3*t)"}}
    return yaml.safe_dump(data)


def test_a_scene_with_parameters_loads_to_the_numbers_it_names():
    scene = load_scene(yaml.safe_load(SPATIAL_WITH_PARAMETERS))
    plain = load_scene(yaml.safe_load(SPATIAL_WITH_NUMBERS))
    E, I, rho, A = 7.0e10, 2.0e-9, 2700.0, 3.0e-5
    s, p = scene.sections["tube"], plain.sections["tube"]
    assert (s.EA, s.EIy, s.EIz, s.GJ, s.rhoA) == (E * A, E * I, 1.3 * E * I, 0.8 * E * I, rho * A)
    for name in ("EA", "EIy", "EIz", "GJ", "rhoA", "rhoIy", "rhoIz"):
        assert getattr(s, name) == pytest.approx(getattr(p, name), rel=1e-15)
    assert np.allclose(scene.bodies["tip"].at, [0.8, 0.3 * 0.8, 0.2 * 0.8], rtol=1e-15, atol=0)
    assert scene.bodies["tip"].mass == 0.05
    assert scene.beams["arm"].elements == 3
    assert np.array_equal(scene.initial_velocity.angular, [0, 0, 0.7])
    assert scene.solve.dt == 0.01
    law, plain_law = scene.beams["arm"].start.hinge.stiffness, plain.beams["arm"].start.hinge.stiffness
    for theta in (-0.4, 0.0, 0.05, 0.9):
        assert law.value(theta, 0.0, 0.0) == pytest.approx(plain_law.value(theta, 0.0, 0.0), rel=1e-15)
        assert law.d_theta(theta, 0.0, 0.0) == pytest.approx(plain_law.d_theta(theta, 0.0, 0.0), rel=1e-14)
    force = scene.loads[0].force[0]
    assert force.value(0.3) == pytest.approx(0.4 * np.sin(1.5), rel=1e-15)
    # the law keeps the values, not the names: it pickles and compiles on its own
    again = pickle.loads(pickle.dumps(law))
    assert again.value(0.7, 0.0, 0.0) == law.value(0.7, 0.0, 0.0)


def test_the_record_says_what_depends_on_each_parameter():
    scene = load_scene(yaml.safe_load(SPATIAL_WITH_PARAMETERS))
    params = scene.parameters
    assert list(params.values) == ["E", "I", "rho", "A", "L", "m", "k", "theta0", "F", "w", "n"]
    assert params.depending_on("L") == ["bodies.tip.at[0]", "bodies.tip.at[1]", "bodies.tip.at[2]"]
    assert params.depending_on("k") == ["beams.arm.start.hinge.stiffness", "beams.arm.start.hinge.damping"]
    assert set(params.depending_on("F")) == {"loads[0].force[0]", "loads[0].force[2]", "loads[0].moment[1]"}
    assert params.depending_on("n") == ["beams.arm.elements"]
    assert params.depending_on("w") == ["initial_velocity.angular[2]"]
    assert params.derivative("sections.tube.EIy", "E") == "2.00000000000000e-9"
    assert params.derivative("sections.tube.EIy", "rho") == "0"


@pytest.mark.parametrize("key, name, where", [
    # (key path, parameter, values of (theta, theta_dot, t) at which the derivative is compared)
    ("beams.arm.start.hinge.stiffness", "k", [(0.3, 0.0, 0.0), (-1.1, 0.0, 0.0)]),
    ("beams.arm.start.hinge.stiffness", "theta0", [(0.3, 0.0, 0.0), (-1.1, 0.0, 0.0)]),
    ("loads[0].force[0]", "F", [(0.0, 0.0, 0.2), (0.0, 0.0, 1.7)]),
    ("sections.tube.GJ", "I", [(0.0, 0.0, 0.0)]),
    ("bodies.tip.inertia[2]", "m", [(0.0, 0.0, 0.0)]),
])
def test_recorded_derivatives_agree_with_central_differences_of_the_scene(key, name, where):
    """∂(number or law at ``key``)/∂(parameter), symbolic, against (f(p + h) − f(p − h))/2h of the
    scene loaded at perturbed values, extrapolated (Richardson) from h and h/2."""
    import sympy as sp

    base = yaml.safe_load(SPATIAL_WITH_PARAMETERS)
    scene = load_scene(base)
    derivative = sp.sympify(scene.parameters.derivative(key, name))
    theta, theta_dot, t = sp.symbols("theta theta_dot t")

    def value_at(p, point):
        data = yaml.safe_load(SPATIAL_WITH_PARAMETERS)
        data["parameters"][name] = p
        s = load_scene(data)
        th, rate, time = point
        if key.startswith("beams"):
            return s.beams["arm"].start.hinge.stiffness.value(th, rate, time)
        if key.startswith("loads"):
            return s.loads[0].force[0].value(time)
        if key.startswith("sections"):
            return s.sections["tube"].GJ
        return s.bodies["tip"].inertia[2, 2]

    p0 = base["parameters"][name]
    h = 1e-3 * abs(p0)
    for point in where:
        exact = float(derivative.subs({theta: point[0], theta_dot: point[1], t: point[2]}))
        central = [(value_at(p0 + d, point) - value_at(p0 - d, point)) / (2 * d) for d in (h, h / 2)]
        richardson = (4 * central[1] - central[0]) / 3
        assert richardson == pytest.approx(exact, rel=1e-8, abs=1e-12 * max(1.0, abs(exact)))


def test_a_3d_scene_with_parameters_runs_as_the_scene_with_numbers(tmp_path):
    """Through the CLI and the API: the same probes (the parameterised scene's numbers are the
    same to round-off: 1.3*E*I and 182.0 may differ in the last bit)."""
    run, out = latdyn_run(tmp_path, SPATIAL_WITH_PARAMETERS)
    assert run.returncode == 0, run.stderr
    with_parameters = probe_columns(out)
    with_numbers = latdyn.run(latdyn.load_scene(yaml.safe_load(SPATIAL_WITH_NUMBERS))).probes
    assert len(with_parameters["t"]) == 4
    for name in ("tip_z", "tip_vy", "hinge"):
        scale = np.abs(with_numbers[name]).max()
        assert scale > 0
        assert np.abs(with_parameters[name] - with_numbers[name]).max() <= 1e-12 * scale
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(SPATIAL_WITH_PARAMETERS)))
    assert np.abs(api.probes["hinge"] - with_parameters["hinge"]).max() <= 1e-12 * np.abs(api.probes["hinge"]).max()


def test_a_planar_scene_with_parameters_runs_exactly_as_with_numbers():
    a = latdyn.run(latdyn.load_scene(yaml.safe_load(PLANAR)))
    b = latdyn.run(latdyn.load_scene(yaml.safe_load(_numbers(PLANAR))))
    assert np.abs(a.probes["tip_y"]).max() > 0
    assert np.array_equal(a.probes["tip_y"], b.probes["tip_y"])


def test_the_builder_takes_parameters():
    b = SceneBuilder("built")
    b.parameters(L=1.2, k=5.0)
    b.section("s", EA=1e6, EIy="10*k", EIz=50.0, GJ=40.0, rhoA=0.5)
    b.body("base", at=[0, 0, 0], fixed=True)
    b.body("tip", at=["L", 0, 0], mass="0.1*L")
    b.beam("arm", "base", "tip", "s", elements=2, start=hinge([0, 0, 1], stiffness="k"))
    b.solve(t_end="0.1*L", dt=0.01)
    scene = b.build()
    assert scene.bodies["tip"].at[0] == 1.2 and scene.bodies["tip"].mass == pytest.approx(0.12, rel=1e-15)
    assert scene.beams["arm"].start.hinge.stiffness == 5.0 and scene.sections["s"].EIy == 50.0


def _refused(change) -> SceneError:
    data = yaml.safe_load(PLANAR)
    change(data)
    with pytest.raises(SceneError) as info:
        load_scene(data)
    return info.value


@pytest.mark.parametrize("name", ["t", "pi", "e", "theta", "theta_dot", "s", "s_dot", "sin", "Piecewise",
                                  "lambda"])
def test_a_parameter_named_like_a_word_of_the_expression_language_is_refused(name):
    assert name in RESERVED or name == "lambda"
    error = _refused(lambda d: d["parameters"].update({name: 1.0}))
    assert error.key == f"parameters.{name}" and "expected another parameter name" in error.expected


@pytest.mark.parametrize("value, expected", [
    ({"2k": 1.0}, "letters, digits and _"),
    ({"k": "t"}, "constant expression"),
    ({"k": True}, "expected a number"),
    ({"k": [1, 2]}, "expected a number"),
    ({"k": 1e308 * 10}, "finite number"),
    ({"tip_y": 1.0}, "name of a probe"),
    ({"k2": "2*k"}, "may not name parameters (k)"),
])
def test_bad_parameters_are_refused_naming_the_parameter(value, expected):
    error = _refused(lambda d: d["parameters"].update(value))
    assert error.key == f"parameters.{next(iter(value))}" and expected in error.expected


def test_an_unknown_name_is_refused_naming_the_key_path_the_name_and_the_parameters():
    error = _refused(lambda d: d["beams"]["arm"]["start"]["hinge"].update(stiffness="k*kk + theta"))
    assert error.key == "beams.arm.start.hinge.stiffness"
    assert "'kk'" in error.expected and "'k*kk + theta'" in error.expected and "L, k, c, P" in error.expected
    error = _refused(lambda d: d["beams"]["arm"].update(to=["L", "H", 0]))
    assert error.key == "beams.arm.to[1]" and "'H'" in error.expected
    error = _refused(lambda d: d.update(parameters="L"))
    assert error.key == "parameters" and "mapping" in error.expected


def test_a_name_of_a_part_is_never_read_as_a_parameter():
    """A body named like a parameter stays a body where a name is expected."""
    data = yaml.safe_load(PLANAR)
    data["bodies"]["L"] = {"at": [0, 0, 0], "fixed": True}
    data["beams"]["arm"]["from"] = "L"
    scene = load_scene(data)
    assert scene.beams["arm"].start.body == "L" and scene.beams["arm"].end.point[0] == 1.2


def test_sensitivities_name_parameters_and_the_explicit_method_refuses_them():
    """Names are checked by the loader; the implicit transient methods differentiate their steps
    (tests/test_sensitivities_transient.py), the explicit one does not and is refused rather than
    approximated."""
    data = yaml.safe_load(PLANAR)
    data["solve"]["sensitivities"] = ["k"]
    assert ("tip_y", "k") in latdyn.run(load_scene(data)).sensitivities
    data["solve"]["method"] = "explicit"
    with pytest.raises(SceneError) as info:
        latdyn.run(load_scene(data))
    assert info.value.key == "solve.sensitivities" and "explicit" in info.value.expected
    error = _refused(lambda d: d["solve"].update(sensitivities=["kk"]))
    assert error.key == "solve.sensitivities[0]" and "L, k, c, P" in error.expected
    error = _refused(lambda d: d["solve"].update(sensitivities=["k", "k"]))
    assert error.key == "solve.sensitivities[1]"


def test_check_lists_the_parameters_and_what_uses_them(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text(PLANAR)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-m", "latdyn", "check", str(scene)], capture_output=True, text=True,
                          env=env, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert "parameters: 4" in done.stdout
    assert "k = 5  (beams.arm.start.hinge.stiffness)" in done.stdout
    assert "L = 1.2  (beams.arm.to[0])" in done.stdout


def test_a_study_varies_a_parameter_and_refuses_one_the_scene_lacks(tmp_path):
    from latdyn.studies.runner import expand, load_study

    (tmp_path / "scene.yaml").write_text(PLANAR)
    study = {"scene": "scene.yaml", "vary": {"parameters.k": [2.0, 8.0]}, "error": {"probe": "tip_y"},
             "reference": {"overrides": {"solve.dt": 0.005}}}
    spec = load_study(study, base_dir=tmp_path)
    stiffness = [load_scene(case.raw).beams["arm"].start.hinge.stiffness for case in expand(spec)]
    assert stiffness == [2.0, 8.0]
    with pytest.raises(SceneError) as info:
        load_study({**study, "vary": {"parameters.kk": [1.0]}}, base_dir=tmp_path)
    assert info.value.key == "vary.parameters.kk" and "L, k, c, P" in info.value.expected
