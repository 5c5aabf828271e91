"""The slider-crank (issue 32, item 2's checks).

The flexible slider-crank of Simo & Vu-Quoc's proportions (crank 0.152 m, steel rod 0.304 m of 6 mm,
the crank run up to 150 rad/s; ``benchmarks/slider_crank.py`` has the problem and the long study):
the rod's mid-span deflection against Exudyn's converged history of the same problem
(``benchmarks/references/slider_crank.json``, 16 ANCF cable elements, h = 2e-5 s), through the CLI in
the plane z = 0 and through the API in a plane turned in space; a free crank with a flywheel on a
flexible rod, whose energy stays at the work that spun it up.

The rigid slider-crank, a closed loop of rigid links computed by closure edges (docs/guides.md, "The
rigid slider-crank"): a prescribed crank against the exact kinematics, a free crank with a flywheel
against Lagrange's equation integrated apart, the drive torque and the frequency against the
Lagrangian, the tangent against central differences and the compiled step's matrix against Python's,
the generated closure kernels against differences, resume bit for bit; and the refusals, with their
key, of the loops it does not cover.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import latdyn
from cli_runs import latdyn_run, probe_columns

REFERENCE = Path(__file__).resolve().parents[1] / "benchmarks" / "references" / "slider_crank.json"

FLEXIBLE_SLIDER_CRANK = """
title: flexible slider-crank, the crank run up to 150 rad/s over 30 ms
sections:
  crank: {EA: 1.0e9, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
  rod: {EA: 5654867.0, EIy: 12.72345, EIz: 12.72345, GJ: 9.787269, rhoA: 0.222519}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  pin: {at: [0.152, 0, 0]}
  slider: {at: [0.456, 0, 0], mass: 0.03382289, guide: {axis: [1, 0, 0]}}
beams:
  crank:
    from: hub
    to: pin
    section: crank
    rigid: true
    start: {hinge: {axis: [0, 0, 1], angle: "Piecewise((75*(t - 0.03/pi*sin(pi*t/0.03)), t < 0.03), (150*(t - 0.015), True))"}}
  rod:
    from: pin
    to: slider
    section: rod
    elements: 8
    start: {hinge: {axis: [0, 0, 1]}}
    end: {hinge: {axis: [0, 0, 1]}}
solve: {analysis: transient, t_end: 0.12, dt: 1.0e-4, rho_inf: 0.9}
output:
  every: 5.0e-4
  probes:
    pin_x: {point: rod.node[0], quantity: position, component: x}
    pin_y: {point: rod.node[0], quantity: position, component: y}
    mid_x: {point: rod.node[4], quantity: position, component: x}
    mid_y: {point: rod.node[4], quantity: position, component: y}
    end_x: {point: rod.node[8], quantity: position, component: x}
    end_y: {point: rod.node[8], quantity: position, component: y}
"""


def reference():
    data = json.loads(REFERENCE.read_text())
    return np.asarray(data["t"]), np.asarray(data["deflection_m"]), np.asarray(data["slider_x_m"])


def deflection(pin, mid, end, normal):
    """The middle node's signed distance from the chord pin → end (rows of points), by ``normal``."""
    chord, arm = end - pin, mid - pin
    return np.cross(chord, arm) @ normal / np.linalg.norm(chord, axis=1)


def test_flexible_slider_crank_mid_span_deflection_against_exudyn(tmp_path):
    """Through the CLI: the rod's mid-span deflection (peak 4.2 mm) over two and a half turns against the
    peer's converged history, and the slider's travel (which the rod's bending moves by up to 0.15 mm
    from the rigid kinematics) against the peer's."""
    completed, out = latdyn_run(tmp_path, FLEXIBLE_SLIDER_CRANK)
    assert completed.returncode == 0, completed.stderr
    c = probe_columns(out)
    point = {n: np.column_stack([c[f"{n}_x"], c[f"{n}_y"], 0.0 * c["t"]]) for n in ("pin", "mid", "end")}
    d = deflection(point["pin"], point["mid"], point["end"], np.array([0.0, 0.0, 1.0]))
    t_ref, d_ref, x_ref = reference()
    assert np.abs(c["t"] - t_ref).max() < 1e-9  # the same rows, 0.5 ms apart
    peak = np.abs(d_ref).max()
    assert 4.0e-3 < peak < 4.5e-3
    # measured 1.95e-3 of the peak (8.2e-6 m): the step's error (dt = 1e-4); at dt = 2e-5 3.3e-7 m, and
    # with the reference's 16 elements and dt, 1.0e-9 m (benchmarks/slider_crank.py, docs/guides.md)
    assert np.abs(d - d_ref).max() < 4e-3 * peak
    assert np.abs(c["end_x"] - x_ref).max() < 2.0e-6  # measured 4.8e-7 m
    assert np.abs(c["end_y"]).max() < 1e-12  # the guide holds the slider on the x axis


def test_flexible_slider_crank_in_a_turned_plane_through_the_api(tmp_path):
    """The same mechanism turned by R (columns (2, 2, −1)/3, (−1, 2, 2)/3, (2, −1, 2)/3: the plane's
    normal is R z), through ``latdyn.run(latdyn.load_scene(...))``: the deflection about R z equals
    the peer's planar history as well as the planar run does, and nothing leaves the turned plane."""
    R = np.array([[2.0, -1.0, 2.0], [2.0, 2.0, -1.0], [-1.0, 2.0, 2.0]]) / 3.0
    normal = R[:, 2]

    def vector(v):
        return "[" + ", ".join(f"{x:.16g}" for x in R @ np.asarray(v, float)) + "]"

    text = FLEXIBLE_SLIDER_CRANK.replace("[0.152, 0, 0]", vector([0.152, 0, 0]))
    text = text.replace("[0.456, 0, 0]", vector([0.456, 0, 0])).replace("[1, 0, 0]", vector([1, 0, 0]))
    text = text.replace("[0, 0, 1]", vector([0, 0, 1]))
    text = text.split("  probes:\n")[0] + "  probes:\n" + "".join(
        f"    {n}_{c}: {{point: rod.node[{k}], quantity: position, component: {c}}}\n"
        for n, k in (("pin", 0), ("mid", 4), ("end", 8)) for c in "xyz")
    assert text.count(vector([0, 0, 1])) == 3
    path = tmp_path / "turned.yaml"
    path.write_text(text)
    result = latdyn.run(latdyn.load_scene(str(path)))
    point = {n: np.column_stack([result.probes[f"{n}_{c}"] for c in "xyz"]) for n in ("pin", "mid", "end")}
    d = deflection(point["pin"], point["mid"], point["end"], normal)
    t_ref, d_ref, x_ref = reference()
    peak = np.abs(d_ref).max()
    assert np.abs(d - d_ref).max() < 4e-3 * peak  # measured 1.95e-3 of the peak, as in the plane
    assert max(np.abs(p @ normal).max() for p in point.values()) < 1e-9  # measured 8.0e-11 m
    slide = point["end"] @ R[:, 0]
    assert np.abs(slide - x_ref).max() < 2.0e-6


FLYWHEEL_SLIDER_CRANK = """
title: a slider-crank with a free crank and a flywheel, spun up by a torque, then left alone
sections:
  crank: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 2.0}
  rod: {EA: 1.0e7, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 0.5}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  pin: {at: [0.1, 0, 0], mass: 5.0}
  slider: {at: [0.4, 0, 0], mass: 1.0, guide: {axis: [1, 0, 0]}}
beams:
  crank:
    from: hub
    to: pin
    section: crank
    rigid: true
    start: {hinge: {axis: [0, 0, 1], torque: "Piecewise((2.0, t < 0.2), (0, True))"}}
  rod:
    from: pin
    to: slider
    section: rod
    elements: 4
    start: {hinge: {axis: [0, 0, 1]}}
    end: {hinge: {axis: [0, 0, 1]}}
solve: {analysis: transient, t_end: 1.0, dt: 0.001, rho_inf: 1.0}
output:
  every: 0.01
  probes:
    total: {energy: total}
    work: {energy: external_work}
    slide: {guide: slider, quantity: position}
    crank: {hinge: crank.start, quantity: angle}
"""


def test_free_crank_with_a_flywheel_conserves_energy(tmp_path):
    """Through the API: a crank with a 5 kg flywheel mass at its pin, driven by 2 N m for 0.2 s and then
    free, turns a stiff flexible rod and a 1 kg slider through both dead centres (θ reaches 6.6 rad):
    after the drive the total energy stays at the work done, and the slide follows the crank angle by
    the loop's kinematics x = R cos θ + √(L² − R² sin² θ) (R = 0.1, L = 0.3)."""
    path = tmp_path / "flywheel.yaml"
    path.write_text(FLYWHEEL_SLIDER_CRANK)
    result = latdyn.run(latdyn.load_scene(str(path)))
    t, p = result.t, result.probes
    theta = p["crank"]
    assert theta[-1] > 2.0 * np.pi  # a full turn: both dead centres passed
    exact = 0.1 * np.cos(theta) + np.sqrt(0.09 - (0.1 * np.sin(theta)) ** 2)
    assert np.abs(p["slide"] + 0.4 - exact).max() < 1e-6  # measured 2.4e-7 m: the rod's stretch
    free = t > 0.2 + 1e-9
    total = p["total"][free]
    assert np.ptp(total) < 2e-5 * total.mean()  # measured 6.6e-6 of the 1.50 J (rho_inf 1, dt 1e-3)
    assert np.abs(p["total"] - p["work"]).max() < 2e-5 * total.mean()


RIGID_FOUR_BAR = """
title: a four-bar of rigid links
sections:
  bar: {EA: 1.0e9, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
bodies:
  a: {at: [0, 0, 0], fixed: true}
  b: {at: [0, 1, 0]}
  c: {at: [1, 1, 0]}
  d: {at: [1, 0, 0], fixed: true}
beams:
  crank: {from: a, to: b, section: bar, rigid: true, start: {hinge: {axis: [0, 0, 1]}}}
  coupler: {from: b, to: c, section: bar, rigid: true, start: {hinge: {axis: [0, 0, 1]}}}
  rocker: {from: d, to: c, section: bar, rigid: true, start: {hinge: {axis: [0, 0, 1]}},
           end: {hinge: {axis: [0, 0, 1]}}}
solve: {t_end: 0.1, dt: 0.01}
"""


RIGID_TRIANGLE = """
title: two free bodies joined twice by rigid links (a loop back onto the first)
sections:
  bar: {EA: 1.0e9, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
bodies:
  a: {at: [0, 0, 0], mass: 1.0, inertia: [1, 1, 1]}
  b: {at: [1, 0, 0], mass: 1.0, inertia: [1, 1, 1]}
beams:
  out: {from: a, to: b, section: bar, rigid: true, start: {hinge: {axis: [0, 0, 1]}}}
  back: {from: b, to: a, section: bar, rigid: true, start: {hinge: {axis: [0, 0, 1]}}}
solve: {t_end: 0.1, dt: 0.01}
"""


def test_loops_of_rigid_links_are_refused_with_the_key(tmp_path):
    """Loops of rigid links other than a slider-crank's: a four-bar whose three moving bars are rigid, and a
    rigid link back onto the body another one starts at: exit 2, the key of the link that closes the loop
    named, the way out said (a flexible beam, stiff: the rigid kinematics), no traceback."""
    from latdyn.errors import SceneError

    completed, out = latdyn_run(tmp_path, RIGID_FOUR_BAR)
    assert completed.returncode == 2, completed.stderr
    assert "beams.rocker.rigid" in completed.stderr and "reached by two rigid links" in completed.stderr
    assert "rigid: false; a stiff section follows the rigid kinematics" in completed.stderr
    assert "Traceback" not in completed.stderr
    path = tmp_path / "triangle.yaml"
    path.write_text(RIGID_TRIANGLE)
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(str(path)))
    assert refused.value.key == "beams.back.rigid" and "close a loop" in refused.value.expected
    assert "rigid: false; a stiff section follows the rigid kinematics" in refused.value.expected


# ----------------------------------------------------------------------------- the rigid slider-crank
TURN = np.array([[2.0, -1.0, 2.0], [2.0, 2.0, -1.0], [-1.0, 2.0, 2.0]]) / 3.0  # columns: a, b, n of a turned plane


def rigid_slider_crank(rotation=np.eye(3), crank: str = 'angle: "10*t"', solve: str = "t_end: 1.0, dt: 0.01",
                       extra_probes: str = "", pin_mass: float = 0.0, gravity: str = "") -> str:
    """Crank R = 0.1 (hub at the origin), rigid rod L = 0.3, slider of 1 kg on a ground guide along the
    turned x axis, in the plane of normal ``rotation`` z."""
    def vector(v):
        return "[" + ", ".join(f"{x:.16g}" for x in rotation @ np.asarray(v, float)) + "]"

    z = vector([0, 0, 1])
    return f"""
title: a rigid slider-crank (a closed loop of rigid links)
{gravity}
sections:
  bar: {{EA: 1.0e9, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 2.0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
  pin: {{at: {vector([0.1, 0, 0])}, mass: {pin_mass}}}
  slider: {{at: {vector([0.4, 0, 0])}, mass: 1.0, guide: {{axis: {vector([1, 0, 0])}}}}}
beams:
  crank: {{from: hub, to: pin, section: bar, rigid: true, start: {{hinge: {{axis: {z}, {crank}}}}}}}
  rod: {{from: pin, to: slider, section: bar, rigid: true,
        start: {{hinge: {{axis: {z}}}}}, end: {{hinge: {{axis: {z}}}}}}}
solve: {{{solve}}}
output:
  every: 0.01
  probes:
    x: {{point: slider, quantity: position, component: x}}
    y: {{point: slider, quantity: position, component: y}}
    z: {{point: slider, quantity: position, component: z}}
{extra_probes}"""


def exact_slide(theta, R=0.1, L=0.3):
    """x = R cos θ + √(L² − R² sin² θ): the slider's distance from the crank's pivot."""
    return R * np.cos(theta) + np.sqrt(L ** 2 - (R * np.sin(theta)) ** 2)


def test_rigid_slider_crank_with_a_prescribed_crank_follows_the_exact_kinematics(tmp_path):
    """Through the CLI, in the plane z = 0: the crank turned at 10 rad/s (1.6 turns), the rod rigid: the
    slider at R cos θ + √(L² − R² sin² θ) on its guide, to round-off."""
    completed, out = latdyn_run(tmp_path, rigid_slider_crank())
    assert completed.returncode == 0, completed.stderr
    c = probe_columns(out)
    assert np.abs(c["x"] - exact_slide(10.0 * c["t"])).max() < 1e-14  # measured 1.1e-16 m: round-off
    assert np.abs(c["y"]).max() < 1e-14 and np.abs(c["z"]).max() < 1e-14


def crank_reference(t, torque, R=0.1, L=0.3, m_crank=0.2, m_pin=5.0, m_rod=0.6, m_slider=1.0):
    """θ(t) of the rigid slider-crank with a free crank, integrated apart from the package: Lagrange's
    equation of its one coordinate, M(θ) θ̈ + ½ M′(θ) θ̇² = τ(t), with M(θ) the kinetic energy's
    coefficient (crank and rod slender and uniform, pin and slider points), to 1e-12 (SciPy)."""
    import sympy as sp
    from scipy.integrate import solve_ivp

    th = sp.symbols("theta")
    pin = sp.Matrix([R * sp.cos(th), R * sp.sin(th)])
    slider = sp.Matrix([R * sp.cos(th) + sp.sqrt(L ** 2 - R ** 2 * sp.sin(th) ** 2), 0])
    centre, turn = (pin + slider) / 2, sp.asin(-R * sp.sin(th) / L)
    M = (m_crank * R ** 2 / 3 + m_pin * R ** 2 + m_rod * centre.diff(th).dot(centre.diff(th))
         + m_rod * L ** 2 / 12 * turn.diff(th) ** 2 + m_slider * slider.diff(th).dot(slider.diff(th)))
    inertia, slope = sp.lambdify(th, M), sp.lambdify(th, M.diff(th))
    solution = solve_ivp(lambda s, y: [y[1], (torque(s) - 0.5 * slope(y[0]) * y[1] ** 2) / inertia(y[0])],
                         (0.0, float(t[-1])), [0.0, 0.0], rtol=1e-12, atol=1e-14, dense_output=True, max_step=1e-3)
    return solution.sol(t)[0]


def test_rigid_slider_crank_with_a_flywheel_against_lagrange_in_a_turned_plane(tmp_path):
    """Through the API, in the plane of normal (2, −1, 2)/3: a free crank with a 5 kg flywheel mass at the
    pin, spun by τ = 2 sin²(πt/0.4) N m for 0.4 s, then free through both dead centres. The crank angle
    against Lagrange's equation of the one coordinate integrated apart (5.97e-6 rad at dt = 1e-3,
    1.49e-6 at 5e-4 measured in the plane z = 0: the step's second order), the slider on the exact
    kinematics of the measured angle to round-off, and the energy after the drive constant (ρ∞ = 1)."""
    torque = 'torque: "Piecewise((2*sin(pi*t/0.4)**2, t < 0.4), (0, True))"'
    probes = ("    crank: {hinge: crank.start, quantity: angle}\n    total: {energy: total}\n"
              "    work: {energy: external_work}\n")
    path = tmp_path / "flywheel.yaml"
    path.write_text(rigid_slider_crank(TURN, torque, "t_end: 1.0, dt: 0.001, rho_inf: 1.0", probes, pin_mass=5.0))
    result = latdyn.run(latdyn.load_scene(str(path)))
    t, p = np.asarray(result.t), result.probes
    theta = np.asarray(p["crank"])
    reference = crank_reference(t, lambda s: 2.0 * np.sin(np.pi * s / 0.4) ** 2 if s < 0.4 else 0.0)
    assert reference[-1] > 5.5
    assert np.abs(theta - reference).max() < 1.2e-5  # measured 6.0e-6 rad
    slider = np.column_stack([p["x"], p["y"], p["z"]])
    assert np.abs(slider @ TURN[:, 0] - exact_slide(theta)).max() < 1e-12
    assert np.abs(slider @ TURN[:, 1]).max() < 1e-12 and np.abs(slider @ TURN[:, 2]).max() < 1e-12
    free = t > 0.4 + 1e-9
    total = np.asarray(p["total"])
    assert np.ptp(total[free]) < 2e-5 * total[free].mean()
    assert np.abs(total - np.asarray(p["work"])).max() < 2e-5 * total[free].mean()


def test_tangent_of_a_rigid_slider_crank_by_finite_differences():
    """The closure in the reduction (latdyn.assembly.linked, and csrc/links.c in the compiled step): at a
    random crank angle, rate and acceleration, in the turned plane, under oblique gravity and with a
    spring on the crank, K = ∂r/∂q (with the closure's geometric term J_pᵀ D J_p and the slider's and
    rod's wrenches passed to the pin), C = ∂r/∂v and M = ∂r/∂v̇ of the one coordinate against central
    differences; and the iteration matrix and residual the compiled step assembles in C equal Python's."""
    import ctypes

    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.linked import evaluate_linked
    from latdyn.assembly.prepare import prepare
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.step.integrators import AlphaParameters
    from test_rigid import finite_difference

    text = rigid_slider_crank(TURN, "stiffness: 3.0, damping: 0.2", "t_end: 0.1, dt: 0.01", pin_mass=5.0,
                              gravity="gravity: [0.3, -1.0, -9.81]")
    prepared = prepare(latdyn.load_scene(yaml_mapping(text)))
    model, assembler = prepared.model, prepared.assembler
    assert model.n_dofs == 1 and {e.closure for e in model.links.edges} == {"", "rod", "slider"}
    rng = np.random.default_rng(11)
    for _ in range(3):
        state = assembler.advance(prepared.state, rng.uniform(-3.0, 3.0, size=1))
        unpack_free(model, rng.normal(size=1), state.v, state.w, state.theta_dot)
        unpack_free(model, rng.normal(size=1), state.a, state.alpha, state.theta_ddot)
        static = assembler.evaluate(state, matrices=True, inertia=False)
        K, K_fd = static.combined(0.0, 0.0, 1.0, dense=True), finite_difference(prepared, state, "q", inertia=False)
        assert np.abs(K - K_fd).max() < 1e-7 * np.abs(K_fd).max()
        dynamic = assembler.evaluate(state, matrices=True)
        for (cm, cc), what in (((0.0, 1.0), "v"), ((1.0, 0.0), "a")):
            exact, fd = dynamic.combined(cm, cc, 0.0, dense=True), finite_difference(prepared, state, what)
            assert np.abs(exact - fd).max() < 1e-7 * np.abs(fd).max()
        python = evaluate_linked(model.links, assembler, state, True, 1.0, True)
        step = CompiledGeneralizedAlpha(assembler, AlphaParameters.for_method("generalized-alpha", 0.8), 1e-10, 25,
                                        1.0)
        step._setup()
        native, factorization = step._native, step.factorization
        for beta_p, gamma_p in ((0.0, 0.0), (0.0, 1.0), (400.0, 20.0)):
            native.complete_links(state)
            native.evaluate(state, matrices=True, load_factor=1.0, inertia=True, inertia_tangent=False)
            native.library.latdyn_iteration_matrix(native.model_ref, native.work_ref,
                                                   ctypes.byref(native.configuration(state)), beta_p, gamma_p, 0)
            expected = np.asarray(python.combined(beta_p, gamma_p, 1.0, dense=True))
            matrix = factorization.values[factorization.position(np.array([0]), np.array([0]))]
            assert abs(matrix[0] - expected[0, 0]) <= 1e-12 * abs(expected[0, 0])
            assert abs(native.buffers["total"][0] - python.residual[0]) <= 1e-12 * abs(python.residual[0])


def yaml_mapping(text: str) -> dict:
    import yaml

    return yaml.safe_load(text)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_closure_kernels_against_differences(backend):
    """slider_closure_edge and rod_closure_edge (codegen/joints.py, "Closure edges"), in the turned plane at
    random pins, pin velocities and accelerations: the slider on its line at the rod's length from the pin
    and the rod's frame turning its initial direction onto the pin → slider direction (exact to 1e-12);
    child_transfer the derivative of the child's configuration by the pin's, child_rates the first and
    second derivatives along the pin's path p + v t + a t²/2, child_convective the derivative of the
    acceleration by the pin's velocity; slider_ and rod_closure_wrench the transfer's transpose on a
    wrench and its derivative by the pin's position: all against central differences (1e-6 relative)."""
    from latdyn.model.kernels import load_kernels

    kernels = load_kernels(backend, "default")
    a, b, n = TURN[:, 0], TURN[:, 1], TURN[:, 2]
    o, length, u0 = 0.4 * a, 0.3, 0.4 * a - 0.1 * a  # the slider at t = 0, the rod's initial direction (pin 0.1 a)
    data = np.concatenate([o, a, n, [length, 1.0, 0.0, 0.0]])
    rng = np.random.default_rng(5)
    eps = 1e-6
    for rod in (False, True):
        edge_kernel = kernels.rod_closure_edge if rod else kernels.slider_closure_edge
        wrench_kernel = kernels.rod_closure_wrench if rod else kernels.slider_closure_wrench
        for _ in range(3):
            pin = 0.1 * (np.cos(rng.uniform(0, 6.3)) * a + np.sin(rng.uniform(0, 6.3)) * b)
            v, acc = rng.normal(size=3), rng.normal(size=3)
            parent = np.concatenate([pin, np.eye(3).ravel(), v, rng.normal(size=3), acc, rng.normal(size=3)])

            def child(p):
                q = parent.copy()
                q[0:3] = p
                x, T = (out[0] for out in edge_kernel(q[None], data[None])[:2])
                return x, T.reshape(3, 3)

            x, T = child(pin)
            slide = o + a * (a @ (x - o))
            if rod:
                direction = T @ (u0 / np.linalg.norm(u0))
                slider_at = pin + length * direction
                assert np.allclose(x, pin, atol=1e-12) and abs(b @ (slider_at - o)) < 1e-12
                assert abs(n @ direction) < 1e-12 and np.allclose(T @ n, n, atol=1e-12)
            else:
                assert np.allclose(x, slide, atol=1e-12) and abs(np.linalg.norm(x - pin) - length) < 1e-12
                assert np.allclose(T, np.eye(3), atol=1e-15)
            _, _, rates, transfer, joint, convective = (out[0] for out in edge_kernel(parent[None], data[None]))
            assert not np.any(joint)

            def twist(p_plus, p_minus, h):
                (xp, Tp), (xm, Tm) = child(p_plus), child(p_minus)
                W = (Tp - Tm) / (2 * h) @ T.T
                return np.concatenate([(xp - xm) / (2 * h), [W[2, 1], W[0, 2], W[1, 0]]])

            by_pin = np.column_stack([twist(pin + eps * e, pin - eps * e, eps) for e in np.eye(3)])
            scale = np.abs(by_pin).max()
            assert np.abs(transfer.reshape(6, 6)[:, :3] - by_pin).max() < 1e-6 * scale
            assert not np.any(transfer.reshape(6, 6)[:, 3:])
            path = [pin + v * s + 0.5 * acc * s ** 2 for s in (-2e-4, -1e-4, 0.0, 1e-4, 2e-4)]
            velocity = twist(path[3], path[1], 1e-4)
            assert np.abs(rates[:6] - velocity).max() < 1e-6 * np.abs(velocity).max()
            x2 = [child(p)[0] for p in path[1:4]]
            assert np.abs(rates[6:9] - (x2[0] - 2 * x2[1] + x2[2]) / 1e-8).max() < 1e-5 * max(1.0, np.abs(rates[6:]).max())
            if rod:  # the rod's angle from the slider kernel's slider: atan2(b·d, a·d), d = slider − pin
                def angle(p):
                    q = parent.copy()
                    q[0:3] = p
                    d = kernels.slider_closure_edge(q[None], data[None])[0][0] - p
                    return np.arctan2(b @ d, a @ d)

                turn = [angle(p) for p in path[1:4]]
                assert abs(rates[3:6] @ n - (turn[2] - turn[0]) / 2e-4) < 1e-6 * abs(rates[3:6] @ n)
                assert np.allclose(rates[3:6], n * (rates[3:6] @ n), atol=1e-14)
                assert abs(rates[9:] @ n - (turn[0] - 2 * turn[1] + turn[2]) / 1e-8) < 1e-5 * max(1.0, abs(rates[9:] @ n))
            columns = []
            for k in range(6):
                up, down = parent.copy(), parent.copy()
                up[12 + k] += eps
                down[12 + k] -= eps
                columns.append((edge_kernel(up[None], data[None])[2][0] - edge_kernel(down[None], data[None])[2][0])
                               / (2 * eps))
            by_rate = np.column_stack(columns)
            assert np.abs(by_rate[6:] - convective.reshape(6, 7)[:, :6]).max() < 1e-6 * max(1.0, np.abs(by_rate).max())
            r = rng.normal(size=6)
            g, D = (out[0] for out in wrench_kernel(pin[None], data[None], r[None]))
            assert np.allclose(g, transfer.reshape(6, 6)[:, :3].T @ r, rtol=0, atol=1e-12 * np.abs(g).max())
            by_position = np.column_stack([(wrench_kernel((pin + eps * e)[None], data[None], r[None])[0][0]
                                            - wrench_kernel((pin - eps * e)[None], data[None], r[None])[0][0])
                                           / (2 * eps) for e in np.eye(3)])
            assert np.abs(D.reshape(3, 3) - by_position).max() < 1e-6 * np.abs(by_position).max()


@pytest.mark.parametrize("change, key, words", [
    (("[0.1, 0, 0]", "[0.25, 0, 0]"), "beams.rod.rigid", "cannot close the loop at every crank angle"),
    (("rod: {from: pin, to: slider, section: bar, rigid: true,\n        start: {hinge: {axis: [0, 0, 1]}}",
      "rod: {from: pin, to: slider, section: bar, rigid: true,\n        start: {hinge: {axis: [0, 0, 1], stiffness: 2}}"),
     "beams.rod.start.hinge", "no stiffness"),
    (("end: {hinge: {axis: [0, 0, 1]}}}", "end: {hinge: {axis: [0, 1, 0]}}}"), "beams.rod.end.hinge", "not planar"),
    (("guide: {axis: [1, 0, 0]}", "guide: {axis: [1, 0, 0], limits: [-0.5, 0.5]}"), "bodies.slider.guide",
     "no stiffness"),
    (("    x: {point: slider", "    s: {guide: slider, quantity: position}\n    x: {point: slider"),
     "output.probes.s", "no coordinate"),
    (("solve:", "  arm: {from: slider, to: [0.4, 0.2, 0], section: bar, rigid: true}\nsolve:"), "beams.rod.rigid",
     "carries a rigid link or a guide of its own"),
])
def test_bad_rigid_loops_are_refused_with_the_key(tmp_path, change, key, words):
    """A crank whose turn would pull the rod past the guide (R = 0.25 against L = 0.15: a dead point, then
    no closure), a law on a hinge or on the guide of the loop, a loop that is not planar, a probe of a
    joint without a coordinate, and a rigid link hung from the slider: a SceneError with the key through
    the API; the first through the CLI too (exit 2, no traceback)."""
    from latdyn.errors import SceneError

    text = rigid_slider_crank().replace(*change)
    assert text != rigid_slider_crank()
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(str(path)))
    assert refused.value.key == key and words in refused.value.expected, str(refused.value)
    if "0.25" in change[1]:
        completed, _ = latdyn_run(tmp_path, text)
        assert completed.returncode == 2, completed.stderr
        assert key in completed.stderr and words in completed.stderr, completed.stderr
        assert "Traceback" not in completed.stderr


def test_drive_torque_and_frequency_of_a_rigid_slider_crank(tmp_path):
    """In the turned plane, through the API: the torque a crank turned at a constant 10 rad/s needs, the
    reaction of its prescribed angle through the closure, is ½ M′(θ) θ̇² (the Lagrangian of
    crank_reference), and with a spring k = 3 on a free crank instead, the one mode about the start has
    f = √(k/M(0))/2π, M(0) = R² (m_crank/3 + m_pin + m_rod/3) (the slider at rest at the dead centre, the
    rod turning at −(R/L) θ̇ about a centre moving at R θ̇/2)."""
    import sympy as sp

    R, L, m_crank, m_pin, m_rod, m_slider = 0.1, 0.3, 0.2, 5.0, 0.6, 1.0
    th = sp.symbols("theta")
    pin = sp.Matrix([R * sp.cos(th), R * sp.sin(th)])
    slider = sp.Matrix([R * sp.cos(th) + sp.sqrt(L ** 2 - R ** 2 * sp.sin(th) ** 2), 0])
    centre, turn = (pin + slider) / 2, sp.asin(-R * sp.sin(th) / L)
    M = (m_crank * R ** 2 / 3 + m_pin * R ** 2 + m_rod * centre.diff(th).dot(centre.diff(th))
         + m_rod * L ** 2 / 12 * turn.diff(th) ** 2 + m_slider * slider.diff(th).dot(slider.diff(th)))
    slope = sp.lambdify(th, M.diff(th))
    path = tmp_path / "driven.yaml"
    path.write_text(rigid_slider_crank(TURN, 'angle: "10*t"', "t_end: 1.0, dt: 0.01",
                                       "    tau: {hinge: crank.start, quantity: torque}\n", pin_mass=5.0))
    result = latdyn.run(latdyn.load_scene(str(path)))
    exact = 0.5 * slope(10.0 * np.asarray(result.t)) * 100.0
    assert np.abs(np.asarray(result.probes["tau"]) - exact).max() < 1e-12 * np.abs(exact).max()  # measured 1.9e-15
    path.write_text(rigid_slider_crank(TURN, "stiffness: 3.0", "analysis: modes, count: 1", pin_mass=5.0))
    latdyn.run(latdyn.load_scene(str(path)), tmp_path / "modes")
    frequency = float((tmp_path / "modes" / "modes.csv").read_text().splitlines()[1].split(",")[1])
    M0 = R ** 2 * (m_crank / 3 + m_pin + m_rod / 3)
    assert float(M.subs(th, 0)) == pytest.approx(M0, rel=1e-14)
    assert frequency == pytest.approx(np.sqrt(3.0 / M0) / (2 * np.pi), rel=1e-12)  # measured 3.7e-16


def test_interrupted_rigid_slider_crank_resumes_bit_for_bit_and_draws_it(tmp_path, monkeypatch):
    """The free crank with its flywheel (the Lagrange test's scene, in the plane z = 0, to t = 0.5),
    interrupted at t = 0.3 and resumed: the files equal the uninterrupted run's; the ParaView bodies (from
    which the structure picture is drawn) carry the slider on the exact kinematics of the recorded crank
    angle."""
    from latdyn.results.structure import load_structure
    from test_checkpoint import assert_same_files, interrupt_at

    torque = 'torque: "Piecewise((2*sin(pi*t/0.4)**2, t < 0.4), (0, True))"'
    path = tmp_path / "flywheel.yaml"
    path.write_text(rigid_slider_crank(np.eye(3), torque, "t_end: 0.5, dt: 0.001, rho_inf: 1.0",
                                       "    crank: {hinge: crank.start, quantity: angle}\n", pin_mass=5.0))
    scene = latdyn.load_scene(str(path))
    full, out = tmp_path / "full", tmp_path / "out"
    reference = latdyn.run(scene, full)
    with monkeypatch.context() as m:
        interrupt_at(m, 0.3)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    assert_same_files(full, out)
    history = load_structure(full)
    slider = history.body_points[:, history.bodies[~history.body_fixed]]
    theta = np.interp(history.times, np.asarray(reference.t), np.asarray(reference.probes["crank"]))
    on_rows = np.isin(np.round(history.times, 9), np.round(np.asarray(reference.t), 9))
    assert on_rows.sum() >= 5
    distance = np.abs(slider[on_rows, :, 0] - exact_slide(theta[on_rows])[:, None]).min(axis=1)
    assert distance.max() < 1e-12
