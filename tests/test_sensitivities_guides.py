"""Transient sensitivities of guided bodies (bodies.NAME.guide; latdyn/analyses/transient_sensitivities.py,
docs/parameters.md "Guides"): a guide's stiffness, damping and rest, the guided body's mass and the sections
of the beam that carries it, against Richardson-extrapolated central differences of whole runs (perturbations
1e-4 and 5e-5 relative), through a guide's latch and stop on a moving body; the reduction's M and C,
which the step's derivative uses as they are, against differences of the residual."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.test_sensitivities_events import _run

#: a bead on a rod that a prescribed motion turns at Ω = 2 rad/s, on a spring along the rod: the centrifugal
#: pull mΩ² s against k — the Coriolis and centrifugal terms of a guide on a moving body
BEAD = """
title: a bead on a rod turning at a constant rate, held by a spring
parameters: {k: 3.0, c: 0.1, m: 0.5, rest: 0.05}
bodies:
  rod: {at: [0, 0, 0], motion: {rotation: {axis: [0, 0, 1], angle: "2.0*t"}}}
  bead: {at: [0.2, 0, 0], mass: "m", inertia: [0.001, 0.001, 0.001],
         guide: {'on': rod, axis: [1, 0, 0], stiffness: "k", damping: "c", rest: "rest"}}
solve: {analysis: transient, dt: 0.01, t_end: 1.0, sensitivities: [k, c, m, rest]}
output:
  every: 0.05
  probes:
    x: {point: bead, quantity: position, component: x}
    y: {point: bead, quantity: position, component: y}
    s: {guide: bead, quantity: position}
"""

#: a mass on a skew guide (axis (1, −2, 2)/3) fixed to the tip body of a flexible arm with rotary inertia,
#: out of the coordinate planes, under gravity
GUIDE_3D = """
title: a mass sliding on a skew guide at the tip of a flexible arm, under gravity
parameters: {k: 40.0, c: 0.3, m: 0.4, rest: 0.02, EI: 30.0}
gravity: [0, 0, -9.81]
sections:
  s: {EA: 100000.0, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.0013}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 0.2, inertia: [0.002, 0.003, 0.004]}
  slider: {at: [0.7, 0.35, 0.7], mass: "m", inertia: [0.001, 0.002, 0.0015],
           guide: {'on': tip, axis: [1, -2, 2], stiffness: "k", damping: "c", rest: "rest"}}
beams:
  arm: {from: base, to: tip, section: s, elements: 3}
solve: {analysis: transient, dt: 0.005, t_end: 0.4, sensitivities: [k, m, EI, rest]}
output:
  every: 0.01
  probes:
    s: {guide: slider, quantity: position}
    s_rate: {guide: slider, quantity: rate}
    slider_z: {point: slider, quantity: position, component: z}
    slider_y: {point: slider, quantity: position, component: y}
    mid_x: {point: "arm.node[1]", quantity: displacement, component: x}
"""


def _agree(result, text: str, name: str, tolerance: float = 1e-6) -> float:
    """The largest error of ``result``'s sensitivities by ``name`` (each probe over the rows, relative to its
    largest) against Richardson-extrapolated central differences (1e-4 and 5e-5 relative); the event times'
    derivatives (summary.json event_sensitivities) likewise."""
    p0 = yaml.safe_load(text)["parameters"][name]
    central, times = [], []
    for step in (1e-4 * abs(p0), 5e-5 * abs(p0)):
        up, down = _run(text, name, **{name: p0 + step}), _run(text, name, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"],
                                                                              down.summary["events"])]))
    expected_dt = (4 * times[1] - times[0]) / 3
    computed_dt = [event["dt"][name] for event in result.summary["event_sensitivities"]]
    assert computed_dt == pytest.approx(expected_dt, rel=1e-6), name
    worst = 0.0
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        error = np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max()
        assert error <= tolerance, (probe, name, error)
        worst = max(worst, error)
    return worst


@pytest.fixture(scope="module")
def bead():
    return _run(BEAD)


@pytest.mark.parametrize("name", ["k"])
def test_a_bead_on_a_turning_rod_agrees_with_richardson_central_differences(bead, name):
    """Measured: k 8.5e-10 of each probe's largest sensitivity (and m 3.7e-10, c 2.1e-10, rest 1.1e-10, not
    run here to keep the file fast)."""
    assert bead.probes["s"][-1] > 0.4   # the centrifugal pull drives it out along the rod
    _agree(bead, BEAD, name, tolerance=1e-8)   # measured 8.5e-10


#: GUIDE_3D's slider latching at s = −0.05 (t = 0.240 s), and bouncing off a rigid stop there with
#: restitution 0.5 (ending before it comes back to rest on it)
LATCH_3D = GUIDE_3D.replace('rest: "rest"}}', 'rest: "rest", lock_at: -0.05}}')
STOP_3D = GUIDE_3D.replace('rest: "rest"}}', 'rest: "rest", limits: [-0.05, 1.0], restitution: 0.5}}').replace(
    "t_end: 0.4", "t_end: 0.3")


@pytest.mark.parametrize("text, kind, name", [(LATCH_3D, "latch", "EI"), (STOP_3D, "stop", "m")],
                         ids=["latch-EI", "stop-m"])
def test_a_3d_guide_latching_or_hitting_its_stop_on_a_flexible_arm_agrees_with_richardson_central_differences(
        text, kind, name):
    """The hinges' event machinery on the slide, on a guide whose body moves (the tip of the flexible arm):
    the impulse weight M + dt²K of the reduction depends on the rates through its geometric term, which the
    jump's derivative follows. Measured: latch k 2.4e-8, m 5.0e-9, EI 5.2e-9, rest 1.3e-8; stop k 3.9e-8,
    m 1.1e-8; the event times to 1e-9; without the latch and the stop k 5.7e-9, m 3.3e-10, EI 3.7e-10,
    rest 1.3e-8 (the run before the event is each test's first 0.24 s); the slide's rate probe s_rate with them."""
    result = _run(text, name)
    assert [(e["joint"], e["kind"]) for e in result.summary["events"]] == [("slider", kind)]
    _agree(result, text, name, tolerance=3e-7)   # measured ≤ 3.9e-8


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_the_guided_bodys_rates_derivative_kernel_against_central_differences(backend):
    """prismatic_link_edge_rates_D_q: ∂(v_c, ω_c, a_c, ω̇_c)/∂(δx_p, δπ_p, δs) of prismatic_link_edge's child_rates at
    fixed parent and slide rates, the parent's frame turned as the configuration update turns it
    (T ← exp(skew δπ) T), against central differences, random parents and edges (1e-7)."""
    from latdyn.model.kernels import load_kernels
    from latdyn.numerics.so3 import expm_so3

    kernels = load_kernels(backend, "default")
    rng, eps = np.random.default_rng(7), 1e-6
    for _ in range(3):
        T = expm_so3(rng.normal(size=3))
        parent = np.concatenate([rng.normal(size=3), T.ravel(), rng.normal(size=12)])
        axis = rng.normal(size=3)
        edge = np.concatenate([axis / np.linalg.norm(axis), rng.normal(size=3), rng.normal(size=3), [1.0],
                               rng.normal(size=3)])
        D = np.asarray(kernels.prismatic_link_edge_rates_D_q(parent[None], edge[None])[0]).reshape(12, 7)

        def rates(k, h):
            p, e = parent.copy(), edge.copy()
            if k < 3:
                p[k] += h
            elif k < 6:
                p[3:12] = (expm_so3(np.eye(3)[k - 3] * h) @ T).ravel()
            else:
                e[10] += h
            return np.asarray(kernels.prismatic_link_edge(p[None], e[None])[2]).reshape(12)

        by_differences = np.column_stack([(rates(k, eps) - rates(k, -eps)) / (2 * eps) for k in range(7)])
        assert np.allclose(D, by_differences, rtol=0, atol=1e-7)


@pytest.mark.parametrize("text", [BEAD, GUIDE_3D], ids=["bead", "guide_3d"])
def test_the_step_matrix_of_guided_bodies_is_the_exact_derivative_of_the_residual(text):
    """At random moving states (configuration, rates and accelerations drawn at random) the sensitivities'
    M, C and K of a guided model (TransientSensitivities._matrices, i.e. Assembler.exact_matrices: the reduction's
    M and C, K with the inertia tangents and the dependent rates' q-dependence composed from the generated
    *_rates_D_q kernels) against
    central differences of the residual by the accelerations, the rates and the configuration (measured:
    K 2.0e-12 bead, 4.8e-12 3D, of max|K|; M, C ≤ 1e-9: the residual is linear in v̇ and quadratic in v, so the
    differences take a step of 0.1). The reduction's own K misses the centrifugal
    stiffness −mΩ² of the bead (it is 3, the exact one 1) and is 5e-6 off in 3D."""
    from latdyn.analyses.linearisation import tangent_q_by_differences
    from latdyn.analyses.transient_sensitivities import TransientSensitivities
    from latdyn.assembly.assembler import free_acceleration, free_velocity, unpack_free
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, model = prepared.assembler, prepared.model
    n, rng = model.n_dofs, np.random.default_rng(3)
    state = assembler.advance(prepared.state, 0.05 * rng.standard_normal(n))
    unpack_free(model, rng.standard_normal(n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.standard_normal(n), state.a, state.alpha, state.theta_ddot)
    assembler.complete_links(state)
    M, C, K = TransientSensitivities(prepared)._matrices(state)
    reduction = np.asarray(assembler.evaluate(state, matrices=True).combined(0.0, 0.0, 1.0, dense=True))

    def residual(rates, accelerations):
        moved = state.copy()
        unpack_free(model, rates, moved.v, moved.w, moved.theta_dot)
        unpack_free(model, accelerations, moved.a, moved.alpha, moved.theta_ddot)
        assembler.complete_links(moved)
        return assembler.evaluate(moved, matrices=False).residual

    # the residual is linear in the accelerations and quadratic in the rates: central differences of any step
    # are exact there, so a large one keeps the round-off of the large elastic forces out
    v, a, eta = free_velocity(model, state), free_acceleration(model, state), 0.1
    dM = np.column_stack([(residual(v, a + eta * e) - residual(v, a - eta * e)) / (2 * eta) for e in np.eye(n)])
    dC = np.column_stack([(residual(v + eta * e, a) - residual(v - eta * e, a)) / (2 * eta) for e in np.eye(n)])
    dK = tangent_q_by_differences(assembler, state)
    assert np.abs(dM - M).max() <= 1e-9 * np.abs(M).max()
    assert np.abs(dC - C).max() <= 1e-9 * max(np.abs(C).max(), 1.0)
    assert np.abs(dK - K).max() <= 1e-9 * np.abs(dK).max()
    assert np.abs(dK - reduction).max() >= 1e-6 * np.abs(dK).max()   # what the exact K adds is not round-off


def test_the_cli_writes_a_guided_runs_sensitivities_and_the_api_gives_the_same(tmp_path, bead):
    """``python -m latdyn run`` on the bead as typed: sensitivities.csv (a guide position probe among the
    columns) and summary.json probe_sensitivities equal to the API's run."""
    import json

    from latdyn.results.result import Result
    from tests.cli_runs import latdyn_run

    run, out = latdyn_run(tmp_path, BEAD.replace("'on'", "on"))
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["probe_sensitivities"] == bead.summary["probe_sensitivities"]
    assert summary["probe_sensitivities"]["s"]["end"]["k"] < 0 < summary["probe_sensitivities"]["s"]["end"]["rest"]
    result = Result.load(out)
    assert ("s", "m") in result.sensitivities
    for key, values in bead.sensitivities.items():
        np.testing.assert_array_equal(values, result.sensitivities[key])


STATIC_GUIDE = """
title: a slider on a guide on the tip of a 3D arm, static load control
parameters: {k: 40.0, m: 0.4, F: 1.0, EI: 30.0}
sections:
  s: {EA: 100000.0, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.0013}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 0.2, inertia: [0.002, 0.003, 0.004]}
  slider: {at: [0.7, 0.35, 0.7], mass: "m", inertia: [0.001, 0.002, 0.0015],
           guide: {'on': tip, axis: [1, -2, 2], stiffness: "k", rest: 0.0}}
beams:
  arm: {from: base, to: tip, section: s, elements: 3}
loads:
  - {at: slider, force: ["F", "0.5*F", "-F"]}
solve: {analysis: static, method: load-control, steps: 4, sensitivities: [F, EI]}
output:
  probes:
    sz: {point: slider, quantity: position, component: z}
    sx: {point: slider, quantity: displacement, component: x}
    tz: {point: tip, quantity: position, component: z}
"""


def test_static_sensitivities_of_points_on_a_guided_body_agree_with_central_differences():
    """Static load control of a 3D arm whose tip carries a guided slider: the probes on the slider (a
    dependent node: moved by the reduction's projection, not a coordinate of its own) against central
    differences of whole runs (relative step 1e-5; the path is linear in F, so its differences are exact
    up to round-off). Before the dependent nodes were moved, the slider's sensitivities were exactly 0."""
    def run(**values):
        data = yaml.safe_load(STATIC_GUIDE)
        data["parameters"].update(values)
        if values:
            data["solve"].pop("sensitivities")
        return latdyn.run(latdyn.load_scene(data))

    result = run()
    nominal = yaml.safe_load(STATIC_GUIDE)["parameters"]
    for name in ("F", "EI"):
        h = 1e-5 * nominal[name]
        plus, minus = run(**{name: nominal[name] + h}), run(**{name: nominal[name] - h})
        for probe in ("sz", "sx", "tz"):
            expected = (plus.probes[probe] - minus.probes[probe]) / (2 * h)
            scale = np.abs(expected).max()
            assert scale > 1e-6, (probe, name)
            assert np.abs(result.sensitivities[(probe, name)] - expected).max() <= 1e-7 * scale, (probe, name)


#: the bead on its rod turned by the prescribed angle 2 t + 0.8 t² (a rate that changes: the residual on the slide
#: moves in t), latching at s = 0.1, or bouncing off a rigid stop there (restitution 0.5)
SPUN_BEAD = BEAD.replace('angle: "2.0*t"', 'angle: "2.0*t + 0.8*t**2"')
BEAD_LATCH = SPUN_BEAD.replace('rest: "rest"}}', 'rest: "rest", lock_at: 0.1}}')
BEAD_STOP = SPUN_BEAD.replace('rest: "rest"}}', 'rest: "rest", limits: [-1.0, 0.1], restitution: 0.5}}').replace(
    "t_end: 1.0", "t_end: 0.6")
#: LATCH_3D with the arm's base turned by the prescribed angle 0.5 t² about the skew axis (0.3, −0.2, 1): the
#: slider latches at 0.2563 s
HUB_LATCH_3D = LATCH_3D.replace(
    "base: {at: [0, 0, 0], fixed: true}",
    'base: {at: [0, 0, 0], motion: {rotation: {axis: [0.3, -0.2, 1.0], angle: "0.5*t**2"}}}')


@pytest.mark.parametrize("text, events, name", [(BEAD_LATCH, ["latch"], "k"), (BEAD_STOP, ["stop"], "m"),
                                                (HUB_LATCH_3D, ["latch"], "EI")],
                         ids=["bead-latch-k", "bead-stop-m", "hub-3d-latch-EI"])
def test_a_guide_latching_or_bouncing_on_a_prescribed_motion_agrees_with_richardson_differences(text, events, name):
    """A guide's events beside a prescribed motion (the rod carrying the guide turns; the flexible arm's base
    turns): the residual's time derivative through the prescribed motion at the event's moved time, on the free
    coordinates and, for the reduction's geometric term, on all of them (ExplicitTime ``on_all``). Measured: bead
    latch k 5.5e-9 (after it nothing is free), bead stop m 2.5e-9 (k 1.7e-9), 3D hub latch EI 6.4e-9; the event
    times' derivatives to 1e-7 (the _agree helper)."""
    result = _run(text, name)
    assert [e["kind"] for e in result.summary["events"]] == events
    _agree(result, text, name, tolerance=1e-6)


def test_the_guides_event_check_fails_without_the_prescribed_motions_time_derivative(monkeypatch):
    """The check can fail: with ∂r/∂t through the prescribed motion taken as 0 the bead's bounce is 5.4e-3 off
    (the 3D hub's latch time's derivative off too)."""
    from latdyn.analyses.transient_sensitivities import ExplicitTime

    monkeypatch.setattr(ExplicitTime, "through_prescribed", lambda self, state, inertia=True, on_all=False:
                        np.zeros(self.owner.model.n_total + 1 if on_all else self.owner.model.n_dofs))
    result = _run(BEAD_STOP, "m")
    with pytest.raises(AssertionError):
        _agree(result, BEAD_STOP, "m", tolerance=1e-4)
