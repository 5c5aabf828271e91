"""Sensitivities of the energy and momentum probes (latdyn/analyses/energy_sensitivities.py).

Reference: central differences of whole runs at p ± h and p ± h/2, Richardson-extrapolated (the helpers of
tests/test_sensitivities_transient.py), the perturbation varied, the time step fixed. Checked on a
genuinely 3D structure (two beams at an angle, a hinge whose axis lies in no coordinate plane with a spring,
a rest angle and an applied torque, a joint body with its centre of mass off its node, a load turning with
it, gravity, a spin at t = 0) with rotary inertia, and without it from rest; a static path; the kernel
identities the derivatives rest on (the internal force is the gradient of the strain energy, the inertia
tangent at a = q̇ that of the kinetic energy, the energies linear in the section values); the energy
balance as an invariant of the sensitivities; the CLI's sensitivities.csv; the refusals."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.results.result import Result
from tests.cli_runs import latdyn_run
from tests.test_sensitivities import PLANAR_TURNED
from tests.test_sensitivities_adjoint import _adjoint as adjoint_text
from tests.test_sensitivities_adjoint import _disagreement
from tests.test_sensitivities_contact import WHEEL
from tests.test_sensitivities_events import LATCH_PLANAR
from tests.test_sensitivities_guides import GUIDE_3D, STATIC_GUIDE
from tests.test_sensitivities_joint_forces import DRIVEN_3D
from tests.test_sensitivities_events import _agree as latch_agree
from tests.test_sensitivities_events import _run as latch_run
from tests.test_sensitivities_transient import _agree, _run
from tests.resumed_runs import interrupted_and_whole

ENERGY_PROBES = """
    kinetic: {energy: kinetic}
    strain: {energy: strain}
    potential: {energy: potential}
    work: {energy: external_work}
    lost: {energy: dissipated}
    total: {energy: total}
    px: {momentum: linear, component: x}
    py: {momentum: linear, component: y}
    pz: {momentum: linear, component: z}
    hx: {momentum: angular, component: x}
    hy: {momentum: angular, component: y}
    hz: {momentum: angular, component: z}
"""

SPIN_3D = """
title: 3D arm with a hinged second beam and a joint body, spinning at t = 0 under gravity
gravity: [0, 0, -9.81]
parameters: {F: 2.0, k: 30.0, c: 0.2, th0: 0.1, tau: 0.7, EI: 20.0, G: 15.0, rho: 0.5, m: 0.8, cx: 0.05, J: 0.01}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "1.5*EI", GJ: "G", rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.02*rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0], mass: "m", com: ["cx", 0, "-cx"], inertia: ["J", "J", "2*J"]}
beams:
  a: {from: base, to: knee, section: s, elements: 2, y_axis: [0, 1, 0]}
  b:
    from: knee
    to: [1.6, 0.5, 0.4]
    section: s
    elements: 2
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: "k", damping: "c", rest_angle: "th0", torque: "tau*sin(30*t)"}}
loads:
  - {at: b.end, force: ["0.3*F", "-F", "0.5*F"]}
  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}
initial_velocity: {angular: [0, 0, 2.0]}
solve: {analysis: transient, dt: 0.005, t_end: 0.04, sensitivities: [F, k, c, th0, tau, EI, G, rho, m, cx, J]}
output:
  every: 0.01
  probes:
""" + ENERGY_PROBES

#: SPIN_3D without rotary inertia on the beams (their twist has no inertia), from rest in equilibrium:
#: no gravity, no spin, the loads growing from zero, the rest angle zero
FROM_REST_3D = (SPIN_3D.replace(', rhoIy: "0.01*rho", rhoIz: "0.02*rho"', "")
                .replace("gravity: [0, 0, -9.81]\n", "").replace("initial_velocity: {angular: [0, 0, 2.0]}\n", "")
                .replace('["0.3*F", "-F", "0.5*F"]', '["0.3*F*t", "-F*t", "0.5*F*t"]')
                .replace("th0: 0.1", "th0: 0.0").replace("t_end: 0.04", "t_end: 0.06")
                .replace("    potential: {energy: potential}\n", ""))

STATIC_3D = """
title: 3D hinged arm with a tip body under gravity and a load, static load control
gravity: [0, 0, -9.81]
parameters: {F: 2.0, k: 30.0, th0: 0.1, EI: 20.0, rho: 0.5, m: 0.8, cx: 0.05}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "1.5*EI", GJ: 15.0, rhoA: "rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0], mass: 0.3}
  tip: {at: [1.6, 0.5, 0.4], mass: "m", com: ["cx", 0, "-cx"], inertia: [0.01, 0.01, 0.02]}
beams:
  a: {from: base, to: knee, section: s, elements: 2, y_axis: [0, 1, 0]}
  b:
    from: knee
    to: tip
    section: s
    elements: 2
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: "k", rest_angle: "th0"}}
loads:
  - {at: tip, force: ["0.3*F", "-F", "0.5*F"]}
solve: {analysis: static, steps: 4, sensitivities: [F, k, th0, EI, rho, m, cx]}
output:
  probes:
    strain: {energy: strain}
    potential: {energy: potential}
    total: {energy: total}
"""


@pytest.fixture(scope="module")
def spin_3d():
    return _run(SPIN_3D)


#: one parameter of each kind: a load, the hinge's spring, rest angle, damper and torque, a section
#: stiffness and mass, a body's mass, centre of mass and inertia
@pytest.mark.parametrize("name", ["F", "k", "th0", "c", "tau", "EI", "rho", "m", "cx", "J"])
def test_3d_energy_and_momentum_sensitivities_agree_with_richardson_central_differences(spin_3d, name):
    """A spinning 3D arm under gravity with rotary inertia: every energy and momentum probe (measured
    4e-11 … 2.3e-7 of each probe's largest sensitivity, on 2 loaded cores)."""
    assert len(spin_3d.t) == 5
    _agree(spin_3d, SPIN_3D, name, 1e-6)


@pytest.mark.parametrize("law, names", [
    ("k*(1 + (theta - th0)**2)", ["k", "th0"]),
    ("k*(1 + 0.5*sin(40*t) + 0.1*theta_dot)", ["k", "th0"]),
], ids=["conservative-law", "law-in-t-and-rate"])
def test_spring_laws_agree(law, names):
    """A hinge spring whose stiffness is a law: in θ alone its potential ∫ k(x)(x − θ_r) dx is strain energy
    (its derivatives by the law's parameters on latdyn_energies' own quadrature); in t and θ̇ its work is
    external (the torque −k s in the work). Measured ≤ 8.1e-8 and ≤ 1.4e-7 (H_x, H_y by k and th0)."""
    text = SPIN_3D.replace('stiffness: "k"', f'stiffness: "{law}"').replace(
        "sensitivities: [F, k, c, th0, tau, EI, G, rho, m, cx, J]", f"sensitivities: [{', '.join(names)}]")
    result = _run(text)
    for name in names:
        _agree(result, text, name, 1e-6)


@pytest.mark.parametrize("name", ["G", "rho"])
def test_3d_energy_and_momentum_sensitivities_without_rotary_inertia_from_rest_agree(name):
    """Directions without inertia (the beams' twist), from rest (measured by F, G, rho, J: 4.7e-9, 7.2e-9,
    1.6e-8, 2.8e-9; CI runs G and rho)."""
    _agree(_run(FROM_REST_3D.replace("sensitivities: [F, k, c, th0, tau, EI, G, rho, m, cx, J]",
                                     f"sensitivities: [{name}]")), FROM_REST_3D, name, 1e-6)


@pytest.mark.parametrize("name", ["m"])
def test_energy_and_momentum_sensitivities_through_a_latch_agree(name):
    """The planar arm swung open by its spring until its hinge latches (the kinetic energy and the
    momenta jump there): measured 4.0e-9, 6.8e-8, 1.3e-8, 1.9e-8, 5.9e-9 of each probe's largest sensitivity
    for k, c, EI, rho, m (CI runs m); the 3D wheel's latch and stop: docs/parameters.md."""
    text = LATCH_PLANAR + """    kinetic: {energy: kinetic}
    strain: {energy: strain}
    total: {energy: total}
    hz: {momentum: angular, component: z}
    px: {momentum: linear, component: x}
    py: {momentum: linear, component: y}
"""
    result = latch_run(text)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    latch_agree(result, text, name)


def test_the_external_work_through_a_latch_agrees():
    """The planar arm latching under a constant load: the work's trapezoid carried through the landing step
    (its size moves with the event time), the latch's jump (the loop takes that step's end power after the jump,
    the next step starts from it) and the restart. The loop takes each step's power from its last Newton
    evaluation, within the Newton tolerance of the converged state, so the recorded work is the trapezoid's to
    that tolerance: at the default tol its sensitivities agree to 1.6e-6 (by c), at tol 1e-11 (here) to 1.4e-9 …
    7.4e-9 by P, k, m, c, EI, rho for every probe (3D wheel off a rigid stop under a load: 2.2e-8 by P, 1.7e-8
    by J)."""
    text = (LATCH_PLANAR.replace("solve:", "loads:\n  - {at: tip, force: [\"0.3*P\", \"P\", 0]}\nsolve:")
            .replace("parameters: {", "parameters: {P: 0.4, ").replace("[k, c, EI, rho, m]", "[P]")
            .replace("analysis: transient,", "analysis: transient, tol: 1.0e-11,")
            + "    work: {energy: external_work}\n    total: {energy: total}\n")
    result = latch_run(text)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    latch_agree(result, text, "P")


def test_the_external_work_of_a_prescribed_motion_agrees():
    """The 3D arm swung by a prescribed hinge angle 0.6 sin 4t under gravity (tests/test_sensitivities_joint_forces.py's):
    the drive's power r_d θ̇_d, its reaction's derivative from the exact rows on the prescribed coordinate
    (Assembler.exact_rows). Measured, every probe (the work, the total, H_x, the drive torque, a position): by EI,
    rho, m 4.1e-7, 8.7e-8, 9.6e-8 (CI runs m)."""
    text = (DRIVEN_3D.replace("[EI, rho, m]", "[m]")
            + "    work: {energy: external_work}\n    total: {energy: total}\n    hx: {momentum: angular, component: x}\n")
    _agree(_run(text), text, "m", 1e-6)


def test_the_strain_energy_through_a_compliant_stop_agrees():
    """The 3D wheel of tests/test_sensitivities_contact.py into its compliant stop (to 0.8 s: out of it too): the stop's
    potential k(⟨δ_u⟩ⁿ⁺¹ + ⟨δ_l⟩ⁿ⁺¹)/(n + 1) in the strain energy, by the stop's stiffness (measured to 0.8 s,
    through the onset and the release: strain 5.1e-10, kinetic 4.9e-10, total 4.4e-8; by the hinge's k
    ≤ 1.4e-8, by the stop's damping ≤ 2.4e-9; CI runs kc to 0.3 s); its exponent is refused."""
    text = WHEEL.replace("    angle: {hinge: arm.end, quantity: angle}\n", """    angle: {hinge: arm.end, quantity: angle}
    strain: {energy: strain}
    kinetic: {energy: kinetic}
    total: {energy: total}
""").replace("[kc, nc, cc, k]", "[kc]").replace("t_end: 0.8", "t_end: 0.3")   # the onset at 0.20 … 0.21 s
    latch_agree(latch_run(text), text, "kc")
    with pytest.raises(SceneError, match="exponent of compliant stops"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(text.replace("[kc]", "[kc, nc]"))))


def test_strain_and_potential_energies_with_a_guide_agree():
    """A slider on a skew guide at the tip of a flexible 3D arm under gravity (tests/test_sensitivities_guides.py's
    scenes): its spring's potential ½ k (s − rest)², the guided body's weight moved by the reduction's projection.
    Measured: transient (GUIDE_3D to 0.4 s) by k, m, EI, rest: 5.7e-9, 1.1e-9, 3.0e-9, 1.3e-8; static (STATIC_GUIDE
    under gravity, rest 0.01) by F, EI, m: 4.2e-12, 3.3e-9, 1.8e-12 — CI runs the static one by m (each value
    of a guide's law compiles anew: the transient runs by k and rest cost seconds each). Its kinetic energy,
    total, momenta and external work: tests/test_sensitivities_guide_energies.py."""
    text = (STATIC_GUIDE.replace("solve:", "gravity: [0, 0, -9.81]\nsolve:").replace("[F, EI]", "[m]")
            .replace("rest: 0.0", "rest: 0.01") + """    strain: {energy: strain}
    potential: {energy: potential}
""")
    result = _run(text)
    _agree(result, text, "m", 1e-6)


#: tests/test_sensitivities.py's planar frame whose sections the planar model turns a quarter (EIz = 3 EIy in the
#: plane, ρIz = 3 ρIy), spinning in its plane, a load growing in t, Newton's tolerance tight (the external work)
PLANAR_SPIN = (PLANAR_TURNED.replace("rhoA: 0.5}", 'rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.03*rho"}')
               .replace("parameters: {", "parameters: {rho: 0.5, ")
               .replace("solve: {analysis: static, steps: 3, sensitivities: [P, EI, G]}",
                        "initial_velocity: {angular: [0, 0, 1.5]}\nsolve: {analysis: transient, tol: 1.0e-11, dt: 0.005, "
                        "t_end: 0.05, sensitivities: [P, EI, rho]}")
               .replace("output:\n", "output:\n  every: 0.01\n")
               .replace('force: ["P", "-0.4*P", 0]', 'force: ["P*t", "-0.4*P", 0]')
               + """    kinetic: {energy: kinetic}
    strain: {energy: strain}
    work: {energy: external_work}
    px: {momentum: linear, component: x}
    hz: {momentum: angular, component: z}
""")


@pytest.mark.parametrize("name", ["EI", "rho"])
def test_planar_energy_and_momentum_sensitivities_with_turned_sections_agree(name):
    """The planar model's quarter turns of the section values applied to the energies' explicit derivatives
    (measured by P, EI, rho: 7.3e-11, 2.4e-9, 3.9e-9 at tol 1e-11; at the default tol the work's by EI and rho
    9.1e-7, 4.9e-7: the loop's power from the last Newton evaluation, docs/parameters.md)."""
    _agree(_run(PLANAR_SPIN.replace("[P, EI, rho]", f"[{name}]")), PLANAR_SPIN, name, 1e-6)


@pytest.mark.parametrize("name", ["F", "k", "th0", "EI", "rho", "m", "cx"])
def test_static_strain_and_potential_energy_sensitivities_agree(name):
    _agree(_run(STATIC_3D), STATIC_3D, name, 1e-6)


def test_the_static_paths_external_work_and_kinetic_energy_have_zero_sensitivities():
    """A static path records no external work and no kinetic energy (0 on every row): their derivatives
    are 0, while the strain energy's are not."""
    data = yaml.safe_load(STATIC_3D)
    data["output"]["probes"].update({"work": {"energy": "external_work"}, "kinetic": {"energy": "kinetic"}})
    result = latdyn.run(latdyn.load_scene(data))
    for probe in ("work", "kinetic"):
        assert np.all(result.probes[probe] == 0.0)
        for name in data["solve"]["sensitivities"]:
            assert np.all(result.sensitivities[(probe, name)] == 0.0)
    assert np.abs(result.sensitivities[("strain", "F")]).max() > 1e-3


def _balance_drifts(dt: float, names: list) -> dict:
    """max |δ(total − external_work + dissipated) − its start value| / max |δ total| over the run of SPIN_3D at
    rho_inf = 1 and step ``dt``, by parameter; and under "balance" the same of the energies."""
    text = SPIN_3D.replace("dt: 0.005, t_end: 0.04", f"dt: {dt}, t_end: 0.02, rho_inf: 1.0, tol: 1.0e-11")
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = names
    result = latdyn.run(latdyn.load_scene(data))
    probes = result.probes
    balance = probes["total"] - probes["work"] + probes["lost"]
    out = {"balance": np.abs(balance - balance[0]).max() / np.abs(probes["total"]).max()}
    for name in names:
        total = result.sensitivities[("total", name)]
        held = total - result.sensitivities[("work", name)] + result.sensitivities[("lost", name)]
        out[name] = np.abs(held - held[0]).max() / np.abs(total).max()
    return out


def test_the_energy_balance_holds_for_the_sensitivities():
    """total − external_work + dissipated stays at its start value up to the scheme's balance error, O(h²) at
    rho_inf = 1: so does its derivative, whose drift falls with the step (by 4 once asymptotic).
    Measured, of max |δ total|, at h = 1e-3, 5e-4, 2.5e-4: F 2.4e-5, 6.9e-6, 1.8e-6; k 1.2e-4, 3.0e-5, 7.5e-6; c 2.1e-4,
    5.5e-5, 1.4e-5; tau 3.2e-5, 7.2e-6, 1.7e-6; EI 1.0e-3, 6.7e-4, 1.9e-4; rho 4.6e-6, 2.8e-6, 8.4e-7; m 1.2e-6,
    2.9e-7, 7.2e-8 (from h = 5e-4 on, falling by 3.3 … 4.2); the energies' own balance error 2.2e-6, 5.5e-7,
    1.4e-7."""
    names = ["F", "k", "c", "tau", "EI", "rho", "m"]
    coarse, fine = _balance_drifts(5e-4, names), _balance_drifts(2.5e-4, names)
    assert fine["balance"] < 1e-6
    for name in names:
        assert fine[name] < 1e-3 and coarse[name] / fine[name] > 3.0, (name, coarse[name], fine[name])


@pytest.mark.parametrize("text", [SPIN_3D, FROM_REST_3D], ids=["3d-rotary-inertia-spinning", "3d-without-rotary-inertia"])
def test_the_adjoint_seeded_by_energies_and_momenta_equals_the_forward_method(text):
    """The discrete adjoint seeds each row's energies and momenta with their forms c_qᵀδq + c_vᵀδv + ∂/∂p
    (energy_sensitivities.probe_forms): its end, max and min equal the forward method's (measured 8.6e-15
    spinning, 4.8e-13 from rest, of each output's largest derivative). The external work and the dissipated energy, sums over the steps, are refused there."""
    text = text.replace("    work: {energy: external_work}\n", "").replace("    lost: {energy: dissipated}\n", "")
    forward = _run(text)
    adjoint = _run(adjoint_text(text))
    assert "work" not in forward.probes
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


def test_the_kernel_identities_the_derivatives_rest_on():
    """At a deformed, moving state of the 3D arm: the internal force is the gradient of the strain
    energy (Richardson differences along the configuration update, measured 3e-11 relative), the
    inertia tangent at a = q̇ gives the kinetic energy's, the gravity force the potential's, and the
    strain, kinetic and gravity energies are linear in the section values."""
    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(yaml.safe_load(SPIN_3D)))
    assembler, model = prepared.assembler, prepared.model
    kernels = assembler.kernels
    rng = np.random.default_rng(3)
    n = model.n_dofs
    state = assembler.advance(assembler.initial_state(), 0.05 * rng.standard_normal(n))
    unpack_free(model, rng.standard_normal(n), state.v, state.w, state.theta_dot)
    sections = model.element_sections
    direction = rng.standard_normal(n)

    def inputs(s):
        geometry, rates, _ = assembler.native().element_inputs(s)
        return geometry, rates

    def energies(s):
        geometry, rates = inputs(s)
        E = len(geometry)
        gravity = np.repeat(assembler.gravity[None], E, axis=0)
        return np.array([np.sum(kernels.beam_strain_energy(geometry, sections)[0]),
                         np.sum(kernels.beam_kinetic_energy(geometry, rates, sections)[0]),
                         np.sum(kernels.beam_gravity(geometry, sections, gravity)[1])])

    def richardson(eps):
        def central(e):
            return (energies(assembler.advance(state, e * direction))
                    - energies(assembler.advance(state, -e * direction))) / (2 * e)
        return (4 * central(eps / 2) - central(eps)) / 3

    geometry, rates = inputs(state)
    E = len(geometry)
    forces = [np.asarray(kernels.beam_internal_force(geometry, sections)[0]).reshape(E, 14)]
    tangent = np.asarray(kernels.beam_inertia_tangent(geometry, np.zeros_like(rates), rates, sections,
                                                      np.zeros((E, 3)))[1]).reshape(E, 14, 14)
    forces.append(0.5 * np.einsum("ei,eij->ej", rates, tangent))
    forces.append(-np.asarray(kernels.beam_gravity(geometry, sections, np.repeat(assembler.gravity[None], E, 0))[0]
                              ).reshape(E, 14))
    expected = richardson(5e-4)
    for which, force in enumerate(forces):
        total = np.zeros(model.n_total + 1)
        np.add.at(total, model.element_dofs, force)
        assert abs(total[:n] @ direction - expected[which]) <= 1e-8 * abs(expected[which]), which
    # linear in the section values (L0 kept): f(a + b) = f(a) + f(b) − f(L0 alone), f(2a) = 2 f(a) − f(L0 alone)
    a, b = sections.copy(), sections.copy()
    b[:, 1:8] = rng.uniform(0.5, 2.0, size=(E, 7))
    alone = sections.copy()
    alone[:, 1:] = 0.0
    both = a.copy()
    both[:, 1:8] += b[:, 1:8]
    gravity = np.repeat(assembler.gravity[None], E, axis=0)
    for kernel in (lambda s: kernels.beam_strain_energy(geometry, s)[0],
                   lambda s: kernels.beam_kinetic_energy(geometry, rates, s)[0],
                   lambda s: kernels.beam_gravity(geometry, s, gravity)[1]):
        f = lambda s: np.asarray(kernel(np.ascontiguousarray(s)), float).reshape(-1)  # noqa: E731
        np.testing.assert_allclose(f(both), f(a) + f(b) - f(alone), rtol=1e-12, atol=1e-12 * np.abs(f(both)).max())


def test_the_cli_writes_the_energy_and_momentum_columns(tmp_path):
    """sensitivities.csv through ``latdyn run`` holds the API's energy and momentum columns."""
    text = SPIN_3D.replace("sensitivities: [F, k, c, th0, tau, EI, G, rho, m, cx, J]", "sensitivities: [F, m]")
    run, out = latdyn_run(tmp_path, text, quiet=True)
    assert run.returncode == 0, run.stderr
    header = (out / "sensitivities.csv").read_text().splitlines()[0].split(",")
    assert "total/F" in header and "hz/m" in header and "work/F" in header
    result, api = Result.load(out), _run(text)
    for key, values in api.sensitivities.items():
        np.testing.assert_allclose(result.sensitivities[key], values, rtol=1e-12, atol=1e-14)


def test_an_interrupted_and_resumed_run_has_the_same_energy_sensitivities(tmp_path, monkeypatch):
    """The external work's carried sensitivity rides in the checkpoint with the rest: the resumed
    sensitivities.csv is the uninterrupted one, byte for byte."""
    scene = yaml.safe_load(SPIN_3D.replace("sensitivities: [F, k, c, th0, tau, EI, G, rho, m, cx, J]",
                                           "sensitivities: [F, tau, m]"))
    out, whole = interrupted_and_whole(scene, tmp_path, monkeypatch, 0.022)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
    assert np.any(Result.load(out).sensitivities[("work", "tau")] != 0.0)


@pytest.mark.parametrize("change, expected", [
    (lambda d: d["output"]["probes"].update({"lost": {"energy": "dissipated"}, "work": {"energy": "kinetic"}})
     or d["beams"]["b"]["start"]["hinge"].update({"lock_at": 0.5}), "dissipated energy through the events"),
    (lambda d: d["beams"]["b"]["start"]["hinge"].update({"lock_at": 0.5}), "external work through the events"),
    (lambda d: d["bodies"]["knee"].update({"at": ["1 + 0*F", 0, 0]}), "places the structure"),
    (lambda d: d["solve"].update({"sensitivity_method": "adjoint"}), "(a sum over the steps)"),
])
def test_what_is_not_differentiated_is_refused(tmp_path, change, expected):
    """Refused with exit 2 naming the key, never a number the package cannot stand behind."""
    data = yaml.safe_load(SPIN_3D)
    change(data)
    with pytest.raises(SceneError, match=expected):
        latdyn.run(latdyn.load_scene(data))
    if data["solve"].get("sensitivity_method") == "adjoint":   # once through the CLI: exit 2, the key named
        run, _ = latdyn_run(tmp_path, yaml.safe_dump(data), quiet=True)
        assert run.returncode == 2 and "solve.sensitivity_method" in run.stderr and expected in run.stderr
