"""Transient sensitivities through a compliant stop (latdyn/analyses/transient_sensitivities.py;
docs/parameters.md, "Compliant stops").

The Hunt–Crossley force k⟨δ⟩ⁿ⟨1 + (c/k) δ̇⟩ is continuous at the onset δ = 0, so the state's
sensitivities do not jump there; but the step lands on the onset, and the landing step's size (the
onset's time) is a function of p: without its derivative the hinge stiffness's sensitivities were
off by 1.4e-2 of the angle's and 0.60 of the wheel's coordinates' on the wheel below. The stop's
stiffness, exponent and damping enter ∂r/∂p through the generated ``contact_force_D_law`` (checked here against central
differences of the generated force itself). Reference: central differences of whole runs at p ± h
and p ± h/2, Richardson-extrapolated, the time step fixed; each reference run asks for
sensitivities too (then its steps land on the onset to 1e-12)."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.model.kernels import load_kernels
from tests.cli_runs import latdyn_run

#: a wheel (centre of mass off the hinge) on a hinge at the end of a stiff arm with rotary inertia, out
#: of the coordinate planes (arm along (2, 1, 2)/3, hinge axis (1, −2, 0)/√5); its spring (rest angle 1)
#: drives it into the compliant stop at 0.02 rad (onset between 0.20 and 0.21 s), it bounces and
#: leaves the stop again between 0.73 and 0.74 s
WHEEL = """
title: a wheel on a hinge at the end of a stiff arm, its spring driving it into a compliant stop
parameters: {kc: 300.0, nc: 1.5, cc: 0.5, k: 1.0}
sections: {s: {EA: 1.0e6, EIy: 1.0e4, EIz: 1.0e4, GJ: 8.0e3, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  wheel: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 1.0, com: [0.05, 0, 0],
          inertia: [1.0, 1.0, 1.2]}
beams:
  arm: {from: base, to: wheel, section: s, elements: 1,
        end: {hinge: {axis: [1, -2, 0], stiffness: "k", damping: 0.05, rest_angle: 1.0,
                      limits: [-10, 0.02], contact: {stiffness: "kc", exponent: "nc", damping: "cc"}}}}
solve: {analysis: transient, t_end: 0.8, dt: 0.01, sensitivities: [kc, nc, cc, k]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.end, quantity: angle}
    tip_x: {point: wheel, quantity: position, component: x}
    tip_z: {point: wheel, quantity: displacement, component: z}
"""


def _run(name: str | None = None, **parameters):
    data = yaml.safe_load(WHEEL)
    data["parameters"].update(parameters)
    if name is not None:
        data["solve"]["sensitivities"] = [name]
    return latdyn.run(latdyn.load_scene(data))


@pytest.fixture(scope="module")
def wheel():
    return _run()


def test_the_contact_laws_derivative_kernel_agrees_with_differences_of_the_generated_force():
    """∂f/∂(k, n, c) of ``contact_force_D_law`` against central differences (step 1e-6 relative) of
    ``hinge_force``'s force: in contact on either stop, clipped (a rate pulling away faster than k/c: no
    force, no derivative), outside contact (zero), friction beside it (its law depends on none of them)."""
    kernels = load_kernels("c", "default")
    #               θ      θ̇     lower upper  k     n    c    Fc   Fs   1/vs smooth cv   v0
    cases = [(0.65, 0.3, -0.5, 0.5, 200.0, 1.5, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
             (0.58, -2.0, -0.5, 0.5, 200.0, 1.0, 4.0, 0.2, 0.3, 5.0, 1.0, 0.1, 1e-3),
             (-0.61, -0.7, -0.5, 0.5, 50.0, 2.5, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
             (0.62, -90.0, -0.5, 0.5, 200.0, 1.5, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0),   # clipped
             (0.1, 0.4, -0.5, 0.5, 200.0, 1.5, 3.0, 0.2, 0.3, 0.0, 0.0, 0.0, 1e-3)]     # inside
    for theta, rate, *contact in cases:
        at = np.array([[theta, rate, 0.0, 1.0]])
        row = np.array([contact], float)
        laws = np.zeros((1, 9))
        (computed,) = kernels.contact_force_D_law(at, row)
        computed = np.asarray(computed).reshape(3)
        for slot, column in enumerate((2, 3, 4)):   # stiffness exponent damping
            step = 1e-6 * row[0, column]
            ahead, behind = row.copy(), row.copy()
            ahead[0, column] += step
            behind[0, column] -= step
            force = [float(np.asarray(kernels.hinge_force(at, laws, r)[0]).reshape(-1)[0]) for r in (ahead, behind)]
            expected = (force[0] - force[1]) / (2 * step)
            assert computed[slot] == pytest.approx(expected, rel=1e-7, abs=1e-9), (theta, rate, slot)
    assert not np.any(np.asarray(kernels.contact_force_D_law(np.array([cases[-1][:2] + (0.0, 1.0)]),
                                                             np.array([cases[-1][2:]]))[0]))


def _richardson(name: str, relative: float) -> dict:
    p0 = yaml.safe_load(WHEEL)["parameters"][name]
    h = relative * abs(p0)
    central = []
    for step in (h, h / 2):
        up, down = _run(name, **{name: p0 + step}), _run(name, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


@pytest.mark.parametrize("name, relative", [("kc", 1e-4), ("nc", 1e-4), ("cc", 3e-2), ("k", 1e-4)])
def test_sensitivities_through_a_compliant_stop_agree_with_richardson_differences(wheel, name, relative):
    """Through the onset (landed on) and the release (inside a step), 3D. Measured, of each probe's largest
    sensitivity: kc 1.1e-7, nc 1.8e-8, cc 3.7e-7 (its tip derivatives are small, 1.2e-7 m per N·m·s/rad: the
    differences' own noise falls as 1/h, 3.1e-6, 1.0e-6, 3.7e-7 at 3e-3, 1e-2, 3e-2 relative, the angle's
    2.0e-8, 4.0e-9, 2.5e-9), k 2.7e-7. The onset's time does not depend on the contact's
    law; the hinge stiffness moves it."""
    angle = wheel.probes["angle"]
    assert angle.max() > 0.06 and angle[-1] < 0.02 and angle[20] < 0.02   # onset, penetration, release
    for probe, expected in _richardson(name, relative).items():
        scale = np.abs(expected).max()
        assert scale > 0, (probe, name)
        error = np.abs(wheel.sensitivities[(probe, name)] - expected).max() / scale
        assert error <= 1e-6, (probe, name, error)


def test_the_cli_writes_the_same_sensitivities(tmp_path, wheel):
    """``python -m latdyn run`` on the scene as typed: sensitivities.csv (t first) holds what the API
    gives (the CLI's exit 2 for a refusal: tests/test_sensitivities.py; friction:
    tests/test_sensitivities_friction.py)."""
    run, out = latdyn_run(tmp_path, WHEEL)
    assert run.returncode == 0, run.stderr
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0][:2] == ["t", "angle/kc"]
    for column in ("angle/kc", "tip_x/nc", "tip_z/k"):
        values = np.array([float(r[rows[0].index(column)]) for r in rows[1:]])
        probe, name = column.split("/")
        assert np.allclose(values, wheel.sensitivities[(probe, name)], rtol=1e-12, atol=0), column


#: a 3D arm hinged at its knee (axis in no coordinate plane), its tip load pressing the hinge into a
#: compliant stop at −0.2 rad from λ ≈ 0.4 on (to −0.247 rad at λ = 1): in a static path the stop's
#: force is part of the residual and its derivative part of K
STATIC = """
title: a hinged 3D arm pressed by its tip load into a compliant stop
parameters: {kc: 60.0, nc: 1.5, F: 2.0}
sections: {s: {EA: 1.0e5, EIy: 20.0, EIz: 30.0, GJ: 15.0, rhoA: 0.5}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0]}
beams:
  a: {from: base, to: knee, section: s, elements: 3, y_axis: [0, 1, 0]}
  b:
    from: knee
    to: [1.6, 0.5, 0.4]
    section: s
    elements: 3
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: 3.0, limits: [-0.2, 1],
                    contact: {stiffness: "kc", exponent: "nc", damping: 0.3}}}
loads:
  - {at: b.end, force: ["0.3*F", "-F", "0.5*F"]}
solve: {analysis: static, steps: 6, sensitivities: [kc, nc, F]}
output:
  probes:
    tip_x: {point: b.end, quantity: position, component: x}
    tip_z: {point: b.end, quantity: displacement, component: z}
    hinge: {hinge: b.start, quantity: angle}
"""


@pytest.mark.parametrize("method", ["load-control", "arc-length"])
def test_static_paths_through_a_compliant_stop_agree_with_richardson_differences(method):
    """Measured (h = 1e-3 p): load control kc 2.9e-10, nc 6.2e-11; arc length kc 1.3e-10, nc 1.6e-11
    (the rows and the load factor), of each quantity's largest. No warning of a state past the stop:
    a compliant stop's equilibrium lies past it."""
    def run(names, **parameters):
        data = yaml.safe_load(STATIC)
        data["parameters"].update(parameters)
        data["solve"].update(sensitivities=list(names), method=method)
        return latdyn.run(latdyn.load_scene(data))

    result = run(["kc", "nc", "F"])
    assert result.probes["hinge"].min() < -0.24 and not result.summary.get("warnings")
    for name in ("kc", "nc"):
        p0 = yaml.safe_load(STATIC)["parameters"][name]
        h = 1e-3 * p0
        central = []
        for step in (h, h / 2):
            up, down = run([name], **{name: p0 + step}), run([name], **{name: p0 - step})
            central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
            central[-1]["load_factor"] = (up.t - down.t) / (2 * step)
        for key in central[0]:
            expected = (4 * central[1][key] - central[0][key]) / 3
            got = result.sensitivities.get((key, name), np.zeros_like(expected))   # load control: λ fixed
            scale = np.abs(expected).max()
            if scale == 0:
                assert not np.any(got)
                continue
            assert np.abs(got - expected).max() <= 3e-9 * scale, (method, key, name)   # measured ≤ 2.9e-10


def test_an_arc_length_path_that_starts_on_a_compliant_stop_refuses_its_law():
    """There (the loader allows a start on a limit, not past it) the stop's law moves the start's
    stiffness K₀, and so the first step's length, through the law's second derivative, which is not
    generated: refused (exit 2's SceneError) naming the key."""
    data = yaml.safe_load(STATIC)
    data["beams"]["b"]["start"]["hinge"]["limits"] = [0, 1]   # it starts on the stop (θ = 0)
    data["solve"].update(method="arc-length", sensitivities=["kc"])
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities" and "contact.stiffness" in info.value.expected
