"""Transient sensitivities through joint friction (latdyn/analyses/transient_sensitivities.py; docs/parameters.md,
"Friction").

While a joint slips its friction f = L(v) g(v/v₀) + c_v v (codegen/joints.py ``joint_contact``) is part of the
step's residual: its derivative by the joint's rate is in the step's exact matrix (the generated ``hinge_force``'s
∂f/∂θ̇, as in the run's Newton matrix), its derivatives by the law's values F_c, F_s, 1/v_s, c_v, v₀ come from
the generated ``friction_force_D_law`` (checked here against central differences of the generated force). A stick
and a release come at a step's end: the stick a stop's impulse with restitution 0, the held angle's δθ carried
through K's column of it while stuck, the release a stop's restart; refused (exit 2, naming the friction) only where
that is not followed (beside a controller with states, here). A guide's compliant stops and friction, and a
prescribed slide, too. Reference: central differences of whole runs at p ± h and p ± h/2, Richardson-extrapolated,
the time step fixed (h relative to p: 1e-2 for the values the force depends on weakly — F_s, v_s, v₀, whose tiny
derivatives of the arm's points the differences' noise would swamp at 1e-4 — 3e-2 for a stop's damping, 1e-4 for
the rest)."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.model.kernels import load_kernels
from tests.cli_runs import latdyn_run
from tests.resumed_runs import interrupted_and_whole

#: a wheel (centre of mass off the hinge) driven by a torque about a hinge at the tip of a flexible arm with
#: rotary inertia, in the xy plane (planar: 7 coordinates), against Coulomb-Stribeck-viscous friction whose
#: static level the drive exceeds many times: it slips throughout (tried for sticking at the start, at rest,
#: and where its rate falls into the stick band, the trials undone)
PLANAR = """
title: a wheel driven on a hinge at the tip of a flexible arm against Coulomb-Stribeck-viscous friction (planar)
parameters: {Fc: 0.1, Fs: 0.15, vs: 0.4, cv: 0.05, v0: 0.5, EI: 100.0, tau: 3.0, F: 1.0}
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "EI", GJ: 30.0, rhoA: 2.0, rhoIy: 0.2, rhoIz: 0.2}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  wheel: {at: [1, 0, 0], mass: 1.0, com: [0.1, 0, 0], inertia: [0.1, 0.1, 0.2]}
beams:
  arm:
    from: base
    to: wheel
    section: s
    elements: 2
    end: {hinge: {axis: [0, 0, 1], stiffness: 0.5, torque: "tau",
                  friction: {coulomb: "Fc", static: "Fs", stribeck_rate: "vs", viscous: "cv", stick_rate: "v0"}}}
loads:
  - {at: wheel, force: [0, "F", 0]}
solve: {analysis: transient, t_end: 0.3, dt: 0.005, sensitivities: [Fc, Fs, vs, cv, v0, EI, F]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.end, quantity: angle}
    rate: {hinge: arm.end, quantity: rate}
    wheel_y: {point: wheel, quantity: position, component: y}
    mid_x: {point: "arm.node[1]", quantity: displacement, component: x}
"""

#: the wheel on a skew hinge (axis (1, −2, 0)/√5) at the tip of a flexible arm out of the coordinate planes
#: (along (2, 1, 2)/3), under gravity and a load, against the same friction; its joint torque probed too
SKEW = """
title: a wheel driven on a skew hinge at the tip of a flexible 3D arm against friction
parameters: {Fc: 0.1, Fs: 0.15, vs: 0.4, cv: 0.05, v0: 0.5, EI: 300.0, tau: 3.0, F: 1.0}
gravity: [0, 0, -9.81]
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 2.0, rhoIy: 0.1, rhoIz: 0.13}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  wheel: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 1.0, com: [0.05, 0.02, 0],
          inertia: [0.2, 0.25, 0.3]}
beams:
  arm:
    from: base
    to: wheel
    section: s
    elements: 2
    end: {hinge: {axis: [1, -2, 0], stiffness: 0.5, torque: "tau",
                  friction: {coulomb: "Fc", static: "Fs", stribeck_rate: "vs", viscous: "cv", stick_rate: "v0"}}}
loads:
  - {at: wheel, force: ["0.3*F", "-F", "0.5*F"]}
solve: {analysis: transient, t_end: 0.3, dt: 0.005, sensitivities: [Fc, Fs, vs, cv, v0, EI, F]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.end, quantity: angle}
    rate: {hinge: arm.end, quantity: rate}
    torque: {hinge: arm.end, quantity: torque}
    wheel_y: {point: wheel, quantity: position, component: y}
    mid_z: {point: "arm.node[1]", quantity: displacement, component: z}
"""

#: a mass pushed along a skew guide (axis (1, −2, 2)/3) on the tip body of a flexible arm, out of the coordinate
#: planes, under gravity, into the guide's compliant stop at 0.03 (the onset landed on at t ≈ 0.05, 0.04 deep
#: at t ≈ 0.1) and back out, against friction; reversing in the stop and on the way back it is tried for
#: sticking and let slip
GUIDE = """
title: a mass driven along a skew guide at the tip of a flexible arm into a compliant stop, against friction
parameters: {k: 40.0, m: 0.4, EI: 30.0, P: 8.0, kc: 2000.0, nc: 1.5, cc: 5.0, Fc: 0.2, Fs: 0.3, vs: 0.3, cv: 0.1,
             v0: 0.2}
gravity: [0, 0, -9.81]
sections:
  s: {EA: 100000.0, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.0013}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 0.2, inertia: [0.002, 0.003, 0.004]}
  slider: {at: [0.7, 0.35, 0.7], mass: "m", inertia: [0.001, 0.002, 0.0015],
           guide: {'on': tip, axis: [1, -2, 2], stiffness: "k", damping: 0.3, force: "P",
                   limits: [-1, 0.03], contact: {stiffness: "kc", exponent: "nc", damping: "cc"},
                   friction: {coulomb: "Fc", static: "Fs", stribeck_rate: "vs", viscous: "cv", stick_rate: "v0"}}}
beams:
  arm: {from: base, to: tip, section: s, elements: 3}
solve: {analysis: transient, dt: 0.005, t_end: 0.2, sensitivities: [kc, Fc]}
output:
  every: 0.01
  probes:
    s: {guide: slider, quantity: position}
    s_rate: {guide: slider, quantity: rate}
    force: {guide: slider, quantity: force}
    slider_z: {point: slider, quantity: position, component: z}
    mid_x: {point: "arm.node[1]", quantity: displacement, component: x}
"""

#: a flap hinged to a mass that a prescribed law slides along a skew guide on the tip body of a flexible arm,
#: under gravity, the flap's spring driving it into its compliant stop at 0.05 (the onset landed on at
#: t ≈ 0.015, its time moved by k and by the slide through ∂r/∂t: a prescribed slide's coordinate has no δ, its
#: motion in time enters where an event moves a step's end), out of it again at t ≈ 0.11
PRESCRIBED = """
title: a flap hinged to a mass slid along a skew guide by a prescribed law, its spring driving it into a stop
parameters: {m: 0.4, EI: 30.0, k: 2.0, kc: 300.0}
gravity: [0, 0, -9.81]
sections:
  s: {EA: 100000.0, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.0013}
  f: {EA: 100000.0, EIy: 50.0, EIz: 60.0, GJ: 40.0, rhoA: 0.3, rhoIy: 0.001, rhoIz: 0.001}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 0.2, inertia: [0.002, 0.003, 0.004]}
  slider: {at: [0.7, 0.35, 0.7], mass: "m", inertia: [0.001, 0.002, 0.0015],
           guide: {'on': tip, axis: [1, -2, 2], position: "0.1*(1 - cos(10*t))"}}
  flap_tip: {at: [0.7, 0.35, 0.3], mass: 0.1, inertia: [0.001, 0.001, 0.001]}
beams:
  arm: {from: base, to: tip, section: s, elements: 3}
  flap: {from: slider, to: flap_tip, section: f, elements: 1,
         start: {hinge: {axis: [1, -2, 2], stiffness: "k", rest_angle: 1.0, damping: 0.01,
                         limits: [-1, 0.05], contact: {stiffness: "kc", exponent: 1.5, damping: 0.5}}}}
solve: {analysis: transient, dt: 0.005, t_end: 0.12, sensitivities: [k, kc]}
output:
  every: 0.01
  probes:
    angle: {hinge: flap.start, quantity: angle}
    s: {guide: slider, quantity: position}
    force: {guide: slider, quantity: force}
    flap_z: {point: flap_tip, quantity: position, component: z}
    mid_x: {point: "arm.node[1]", quantity: displacement, component: x}
"""

#: the relative perturbation of each parameter's reference differences (module docstring)
STEP = {"Fs": 1e-2, "vs": 1e-2, "v0": 1e-2, "cc": 3e-2}


def _run(text: str, only: str | None = None, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    if only is not None:
        data["solve"]["sensitivities"] = [only]
    return latdyn.run(latdyn.load_scene(data))


def _errors(result, text: str, name: str) -> dict:
    """{probe: the largest error of ``result``'s sensitivities by ``name`` over the rows, relative to the
    reference's largest} against Richardson-extrapolated central differences of whole runs."""
    p0 = yaml.safe_load(text)["parameters"][name]
    h = STEP.get(name, 1e-4) * abs(p0)
    central = []
    for step in (h, h / 2):
        up, down = _run(text, name, **{name: p0 + step}), _run(text, name, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    errors = {}
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        scale = np.abs(expected).max()
        if scale == 0:   # a prescribed coordinate: its derivative is 0 exactly
            assert not np.any(result.sensitivities[(probe, name)]), (probe, name)
            continue
        errors[probe] = float(np.abs(result.sensitivities[(probe, name)] - expected).max() / scale)
    return errors


@pytest.fixture(scope="module")
def planar():
    return _run(PLANAR)


@pytest.fixture(scope="module")
def skew():
    return _run(SKEW)


@pytest.fixture(scope="module")
def guided():
    return _run(GUIDE)


def test_the_friction_laws_derivative_kernel_agrees_with_differences_of_the_generated_force():
    """∂f/∂(F_c, F_s, 1/v_s, c_v, v₀) of ``friction_force_D_law`` against central differences (step 1e-6
    relative) of ``hinge_force``'s force: slipping fast and inside the stick band, either way, with and
    without the Stribeck decay, a compliant stop beside it (its law depends on none of them)."""
    kernels = load_kernels("c", "default")
    #               θ      θ̇     lower upper  k     n    c    Fc   Fs   1/vs smooth cv   v0
    cases = [(0.1, 0.7, 0.0, 0.0, 0.0, 1.0, 0.0, 0.2, 0.3, 2.5, 1.0, 0.1, 0.5),      # slipping
             (0.1, 0.2, 0.0, 0.0, 0.0, 1.0, 0.0, 0.2, 0.3, 2.5, 1.0, 0.1, 0.5),      # in the band
             (-0.3, -0.35, 0.0, 0.0, 0.0, 1.0, 0.0, 0.4, 0.9, 4.0, 1.0, 0.3, 0.6),   # the other way
             (0.1, 0.2, 0.0, 0.0, 0.0, 1.0, 0.0, 0.2, 0.3, 0.0, 0.0, 0.1, 0.5),      # no Stribeck decay
             (0.58, -0.4, -0.5, 0.5, 200.0, 1.5, 4.0, 0.2, 0.3, 5.0, 1.0, 0.1, 1.0)]  # in a compliant stop
    laws = np.zeros((1, 9))
    for theta, rate, *contact in cases:
        at = np.array([[theta, rate, 0.0, 1.0]])
        row = np.array([contact], float)
        computed = np.asarray(kernels.friction_force_D_law(at, row)[0]).reshape(5)
        for slot, column in enumerate((5, 6, 7, 9, 10)):   # coulomb static 1/stribeck_rate viscous stick_rate
            step = 1e-6 * max(abs(row[0, column]), 1e-3)
            ahead, behind = row.copy(), row.copy()
            ahead[0, column] += step
            behind[0, column] -= step
            force = [float(np.asarray(kernels.hinge_force(at, laws, r)[0]).reshape(-1)[0]) for r in (ahead, behind)]
            expected = (force[0] - force[1]) / (2 * step)
            assert computed[slot] == pytest.approx(expected, rel=1e-7, abs=1e-9), (theta, rate, slot)
        assert np.any(computed)


@pytest.mark.parametrize("name", ["Fc", "Fs", "vs", "cv", "v0"])
def test_planar_slipping_friction_agrees_with_richardson_differences(planar, name):
    """Planar (7 coordinates), slipping throughout (rate ≥ 0, tried for sticking and let slip). Measured, of
    each probe's largest sensitivity: Fc 3.3e-7, Fs 3.1e-7, vs 3.6e-7, cv 2.3e-7, v0 2.9e-7 (EI 3.8e-8, F 6.2e-8
    when tried; the largest on the arm's midpoint's x, whose derivatives by the friction are 1e-4 to 1e-6 m).
    Without the friction's rate derivative in the step's matrix (tried once) Fc, cv and EI were off by 6.1e-2,
    5.0e-2 and 3.1e-2."""
    assert planar.summary["coordinates"] == 7 and planar.probes["rate"].min() >= 0.0
    errors = _errors(planar, PLANAR, name)
    assert max(errors.values()) <= 1e-6, errors


@pytest.mark.parametrize("name", ["Fc", "cv", "EI", "F"])
def test_skew_slipping_friction_agrees_with_richardson_differences(skew, name):
    """3D (13 coordinates): a skew hinge axis, a flexible arm out of the coordinate planes, gravity, the joint's
    torque (its law with the friction: latdyn/analyses/joint_force_sensitivities.py) among the probes. Measured:
    Fc 6.7e-8, cv 4.8e-8, EI 1.9e-9, F 2.6e-7 (Fs 2.0e-8, vs 5.1e-8, v0 5.1e-8 when tried)."""
    assert skew.summary["coordinates"] == 13
    errors = _errors(skew, SKEW, name)
    assert max(errors.values()) <= 1e-6, errors


@pytest.mark.parametrize("name", ["kc", "Fc"])
def test_a_guides_compliant_stop_and_friction_agree_with_richardson_differences(guided, name):
    """A guide's compliant stops as a hinge's (the onset landed on, the law through ``contact_force_D_law``)
    and its friction as a hinge's, on the slide, through the guides' reduction; the guide's force probed.
    Measured: kc 4.2e-9, Fc 1.0e-7 (cc 6.6e-9, v0 7.6e-7, nc 3.6e-9, Fs 5.4e-7, vs 3.3e-7, EI 1.0e-8, P 1.2e-7 when
    tried)."""
    result = guided
    assert result.summary["coordinates"] == 19 and result.summary["steps"] > 40   # landed on the onset
    assert result.probes["s"].max() > 0.06 and result.probes["s_rate"].min() < -0.5   # into the stop and out
    errors = _errors(result, GUIDE, name)
    assert max(errors.values()) <= 1e-6, errors


@pytest.mark.parametrize("name", ["k", "kc"])
def test_a_prescribed_slide_agrees_with_richardson_differences(name):
    """A prescribed slide as a prescribed hinge angle: its coordinate's derivative 0, its reaction (the guide's
    force probe) differentiated as a held joint's, its motion's time derivative in ∂r/∂t where the flap's stop
    onset moves a step's end. Measured: k 6.8e-8, kc 1.7e-7 (the guide's force the largest; EI 1.2e-7, m 6.0e-9
    when tried). Left out of ∂r/∂t (the slide not counted a prescribed motion), k was off by 8.1."""
    result = _run(PRESCRIBED, name)
    angle = result.probes["angle"]
    assert angle.max() > 0.1 and angle[1] < 0.05 < angle[2] and angle[-1] < 0.05   # onset and release
    errors = _errors(result, PRESCRIBED, name)
    assert max(errors.values()) <= 1e-6, errors


def test_the_cli_writes_the_same_sensitivities(tmp_path, planar):
    """``python -m latdyn run`` on the planar scene as typed: sensitivities.csv holds what the API gives."""
    run, out = latdyn_run(tmp_path, PLANAR)
    assert run.returncode == 0, run.stderr
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0][0] == "t"
    for column in ("angle/Fc", "rate/v0", "wheel_y/vs", "mid_x/EI", "angle/F", "rate/Fs", "wheel_y/cv"):
        values = np.array([float(r[rows[0].index(column)]) for r in rows[1:]])
        probe, name = column.split("/")
        assert np.allclose(values, planar.sensitivities[(probe, name)], rtol=1e-12, atol=0), column


#: a panel (I = 1, its centre of mass off the hinge) on a stiff arm, a torque τ = A t on its hinge with friction: it
#: sticks at t = 0 (a run starting at rest: events.stick_at_start), is released at t = 0.31 (the first step's end at
#: which the holding reaction exceeds F_s = 0.305) and slips on against F_c (docs/contact.md); planar, 4 coordinates
STUCK = """
title: a panel stuck by friction until its torque breaks it away
parameters: {Fc: 0.2, Fs: 0.305, A: 1.0, EI: 1000.0, m: 1.0}
sections: {s: {EA: 1.0e6, EIy: "EI", EIz: "EI", GJ: 1000.0, rhoA: 0.1, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  panel: {at: [1, 0, 0], mass: "m", com: [0.2, 0, 0], inertia: [1.0, 1.0, 1.0]}
beams:
  arm: {from: base, to: panel, section: s, elements: 1,
        end: {hinge: {axis: [0, 0, 1], torque: "A*t", friction: {coulomb: "Fc", static: "Fs"}}}}
solve: {analysis: transient, t_end: 0.6, dt: 0.01, sensitivities: [Fc, A, EI, m]}
output:
  probes:
    angle: {hinge: arm.end, quantity: angle}
    rate: {hinge: arm.end, quantity: rate}
    py: {point: panel, quantity: position, component: y}
"""

#: a panel on a skew hinge (1, −2, 0) at the tip of a flexible arm out of the coordinate planes, under gravity, a
#: torque τ = A t on the hinge: stuck from t = 0, released by gravity at t = 0.03, slipping back
#: and forth, stuck again at t = 0.22, released at t = 0.23 by the torque; Newton's tolerance 1e-12 (module
#: docstring of the test below)
STUCK_3D = """
title: a panel on a skew hinge at the tip of a flexible arm, sticking and slipping by friction
parameters: {Fc: 0.2, Fs: 0.305, A: 1.0, EI: 50.0, m: 1.0}
gravity: [0, 0, -9.81]
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.01, rhoIz: 0.013}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  panel: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: "m", com: [0.1, 0.05, 0],
          inertia: [0.3, 0.35, 0.4]}
beams:
  arm: {from: base, to: panel, section: s, elements: 2,
        end: {hinge: {axis: [1, -2, 0], torque: "A*t", friction: {coulomb: "Fc", static: "Fs"}}}}
solve: {analysis: transient, t_end: 0.4, dt: 0.01, tol: 1.0e-12, sensitivities: [Fc, EI]}
output:
  probes:
    angle: {hinge: arm.end, quantity: angle}
    rate: {hinge: arm.end, quantity: rate}
    torque: {hinge: arm.end, quantity: torque}
    pz: {point: panel, quantity: position, component: z}
    mid_y: {point: "arm.node[1]", quantity: displacement, component: y}
"""


@pytest.fixture(scope="module")
def stuck():
    return _run(STUCK)


@pytest.fixture(scope="module")
def stuck_3d():
    return _run(STUCK_3D)


@pytest.mark.parametrize("name", ["Fc", "A", "m"])
def test_sticking_and_release_agree_with_richardson_differences(stuck, name):
    """Planar: stuck from t = 0 to t = 0.31, then slipping (the derivative of the stick's impulse, the
    held angle's δθ through K's column of it while stuck, the release's restart). Measured: Fc 4.0e-10, A 8.1e-11,
    m 6.8e-10 (stuck from t = 0; from the first step's end before: Fc 1.9e-9, A 1.2e-9, m 2.3e-10)."""
    rate = stuck.probes["rate"]
    assert np.all(rate[1:31] == 0.0) and np.all(rate[32:] > 0.0)
    errors = _errors(stuck, STUCK, name)
    assert max(errors.values()) <= 1e-6, errors


@pytest.mark.parametrize("name", ["Fc", "EI"])
def test_sticking_on_and_off_in_3d_agrees_with_richardson_differences(stuck_3d, name):
    """3D, flexible: two sticks and releases, the stuck joint's torque (its reaction, with its own law's and the held
    angle's terms) among the probes. Measured: Fc 8.2e-8, EI 4.6e-8 (1.3e-8, 1.2e-8 since ctrlhand: the held angle's
    columns in the stick's weight derivative W's K's, without the elements' gravity tangent), stuck from t = 0
    (9.6e-8, 6.0e-8 stuck from the first step's end; then A 3.9e-8, m 7.2e-8 when tried; with a spring k = 0.5 on the hinge: k 7.6e-8,
    A 3.7e-8). At Newton's default tolerance (1e-8) Fc's
    were 4.3e-6 off (the slipping steps' iterates, not the derivative: 9e-8 at 1e-13; A, EI, m ≤ 3e-8 either way)."""
    t, rate = stuck_3d.t, stuck_3d.probes["rate"]
    held = np.round(t[(rate == 0.0) & (t > 0)], 6)
    assert list(held) == [0.01, 0.02, 0.03, 0.22, 0.23], held   # the rows while it is stuck (from t = 0)
    errors = _errors(stuck_3d, STUCK_3D, name)
    assert max(errors.values()) <= 1e-6, errors


def test_the_cli_writes_a_stuck_runs_sensitivities(tmp_path, stuck):
    """``python -m latdyn run`` on the stuck panel as typed: sensitivities.csv holds what the API gives, the held
    angle's δθ in the angle's columns while stuck."""
    run, out = latdyn_run(tmp_path, STUCK)
    assert run.returncode == 0, run.stderr
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.reader(f))
    for column in ("angle/Fc", "angle/A", "rate/m", "py/EI"):
        values = np.array([float(r[rows[0].index(column)]) for r in rows[1:]])
        probe, name = column.split("/")
        assert np.allclose(values, stuck.sensitivities[(probe, name)], rtol=1e-12, atol=0), column
    held = stuck.sensitivities[("angle", "A")]   # stuck from t = 0 (events.stick_at_start): held at 0 exactly
    assert not np.any(held[:31]) and np.all(held[32:] != 0.0)   # then slipping as the drive breaks it away


def test_a_stuck_run_resumes_to_the_same_sensitivities(tmp_path, monkeypatch):
    """The held angles' δθ ride in the checkpoint with the rest: interrupted while the panel is stuck, resumed,
    sensitivities.csv is the uninterrupted one byte for byte."""
    scene = yaml.safe_load(STUCK)
    out, whole = interrupted_and_whole(scene, tmp_path, monkeypatch, 0.15)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()


def test_sticking_beside_a_controller_with_states_is_refused_naming_its_friction(tmp_path):
    """What a stuck joint's held angle moves is carried for positions, angles, rates, joint forces, energies and
    momenta, and for controllers that drive the stuck joint, not for a controller with states that drives a free
    coordinate (tests/test_sensitivities_sticks_beside.py): a run with a PI pushing the panel by a load is refused
    when the joint sticks — SceneError naming the joint's friction through the API, exit 2 without a traceback from
    the CLI (which removes the results folder)."""
    text = STUCK.replace("solve:", "controllers:\n  ctl: {output: \"-2*angle - 0.5*S\", states: {S: \"angle\"}}\n"
                                   "loads:\n  - {at: panel, force: [0, \"ctl\", 0]}\nsolve:")
    with pytest.raises(SceneError) as refused:
        _run(text)
    # stuck from the start (events.stick_at_start): refused at t = 0
    assert refused.value.key == "beams.arm.end.hinge.friction" and "at t = 0 " in refused.value.expected
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 2, run.stderr
    assert "beams.arm.end.hinge.friction" in run.stderr and "Traceback" not in run.stderr
    assert not out.exists()


def test_the_dissipated_energy_of_friction_is_refused(tmp_path):
    """The friction's work is declared dissipation (docs/contact.md); its derivative is not carried yet: an
    ``energy: dissipated`` probe beside friction is refused before the run (exit 2 naming solve.sensitivities)."""
    text = PLANAR.replace("    rate: {hinge: arm.end, quantity: rate}\n",
                          "    rate: {hinge: arm.end, quantity: rate}\n    dissipated: {energy: dissipated}\n")
    with pytest.raises(SceneError) as refused:
        _run(text)
    assert refused.value.key == "solve.sensitivities" and "arm.end.friction" in refused.value.expected
    run, _ = latdyn_run(tmp_path, text)
    assert run.returncode == 2 and "dissipated energy of friction" in run.stderr and "Traceback" not in run.stderr


def test_the_adjoint_takes_friction_while_it_slips_and_through_a_stick(planar):
    """The discrete adjoint differentiates friction while the joints slip (refused before the run on 86d57d9): the
    wheel, which slips throughout, equals the forward method's to 1.3e-14 of each output's largest derivative
    (measured); and through a stick and a release (refused when the joint stuck on 40bf44a): the panel stuck from
    t = 0 until its torque breaks it away equals the forward method's (tests/test_adjoint_friction_sticks.py has
    sticks mid-run)."""
    data = yaml.safe_load(PLANAR)
    data["solve"]["sensitivity_method"] = "adjoint"
    adjoint = latdyn.run(latdyn.load_scene(data)).summary["probe_sensitivities"]
    for probe, outputs in planar.summary["probe_sensitivities"].items():
        for which, by_name in outputs.items():
            f = np.array(list(by_name.values()))
            a = np.array([adjoint[probe][which][name] for name in by_name])
            assert np.abs(a - f).max() <= 1e-10 * np.abs(f).max(), (probe, which)
    data = yaml.safe_load(STUCK)
    forward = latdyn.run(latdyn.load_scene(data)).summary["probe_sensitivities"]
    data["solve"]["sensitivity_method"] = "adjoint"
    adjoint = latdyn.run(latdyn.load_scene(data)).summary["probe_sensitivities"]
    for probe, outputs in forward.items():
        for which, by_name in outputs.items():
            f = np.array(list(by_name.values()))
            a = np.array([adjoint[probe][which][name] for name in by_name])
            assert np.abs(a - f).max() <= 1e-10 * max(np.abs(f).max(), 1e-300), (probe, which)
