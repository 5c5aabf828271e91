"""Geometry parameters (docs/parameters.md, "Geometry parameters"): sensitivities by a parameter that moves
the reference configuration — a body's ``at``, a beam's free end, an end's offset.

The generated derivatives of the element forces along a variation of the reference data
(``beam_internal_force_D_reference``, ``beam_inertia_force_D_reference``) against central differences of the
forces, planar and 3D; then whole runs, static and transient, planar and genuinely 3D, against Richardson
central differences of whole runs in the parameter (tests/test_sensitivities_transient.py's ``_richardson``).
"""
from __future__ import annotations

import numpy as np
import pytest

import element_states as es
from latdyn.model.kernels import load_kernels
from test_planar import planar_state, planar_velocity

H = 1e-6


def _reference_moved(state, reference: np.ndarray, eps: float):
    """(geometry (1, 36), section (1, 10)) of ``state`` with its reference data moved by ``eps`` times the
    variation ``reference`` (codegen/conventions.py REFERENCE): reference points and global offsets
    translated, nodal frames turned by exp(skew eps ψ_i) (spatial), L0 changed, global hinge axes moved."""
    g = state.geometry()[0].copy()
    r = eps * reference
    g[0:6] += r[0:6]
    g[6:12] += r[6:12]
    for frame, psi in ((slice(12, 21), r[12:15]), (slice(21, 30), r[15:18])):
        g[frame] = (es.expm_so3(psi) @ g[frame].reshape(3, 3)).ravel()
    g[30:36] += r[19:25]
    section = state.section.copy()
    section[0] += r[18]
    return g[None], section[None]


def _planar_reference(rng, normal: int) -> np.ndarray:
    """A random reference variation that keeps the plane: in-plane translations, turns about n."""
    i, j = (normal + 1) % 3, (normal + 2) % 3
    r = np.zeros(25)
    for block in (0, 3, 6, 9):
        r[block + i], r[block + j] = rng.normal(size=2)
    r[12 + normal], r[15 + normal] = rng.normal(size=2)
    r[18] = rng.normal() * 0.1
    return r


def _check_reference_derivatives(kernels, state, reference, qdot, acceleration, gravity):
    """Both kernels' derivatives along ``reference`` against central differences of their forces."""
    def internal(eps):
        geometry, section = _reference_moved(state, reference, eps)
        return kernels.beam_internal_force(geometry, section)[0][0]

    def inertial(eps):
        geometry, section = _reference_moved(state, reference, eps)
        return kernels.beam_inertia_tangent(geometry, qdot[None], acceleration[None], section, gravity[None])[0][0]

    geometry, section = state.geometry(), state.section[None]
    force, derivative = kernels.beam_internal_force_D_reference(geometry, section, reference[None])
    np.testing.assert_allclose(force[0], internal(0.0), rtol=0, atol=1e-12 * np.abs(force).max())
    numeric = (internal(H) - internal(-H)) / (2 * H)
    assert np.linalg.norm(derivative[0][:, 0] - numeric) <= 1e-6 * np.linalg.norm(numeric)
    force, derivative = kernels.beam_inertia_force_D_reference(geometry, qdot[None], acceleration[None], section,
                                                               gravity[None], reference[None])
    np.testing.assert_allclose(force[0], inertial(0.0), rtol=0, atol=1e-12 * np.abs(force).max())
    numeric = (inertial(H) - inertial(-H)) / (2 * H)
    assert np.linalg.norm(derivative[0][:, 0] - numeric) <= 1e-6 * np.linalg.norm(numeric)


def test_planar_reference_derivatives_against_finite_differences():
    """default_xy: ∂F/∂(reference) and ∂(M a + g − Q)/∂(reference) along in-plane variations (moved fixed
    ends, offsets, frames turned about z, L0; the axes stay ±z) at random planar states with hinges and offsets."""
    kernels = load_kernels(backend="auto", variant="default_xy")
    rng = np.random.default_rng(34)
    for _ in range(3):
        state = planar_state(rng, 2, deformation=0.3)
        gravity = np.array([rng.normal(), rng.normal(), 0.0]) * 9.81
        _check_reference_derivatives(kernels, state, _planar_reference(rng, 2), planar_velocity(rng, 2),
                                     planar_velocity(rng, 2), gravity)


def test_3d_reference_derivatives_against_finite_differences():
    """default (3D): the same, hinge axes moved too, at random states with large rigid rotations, hinges,
    offsets and shear."""
    kernels = load_kernels(backend="auto", variant="default")
    rng = np.random.default_rng(35)
    for regime in es.REGIMES.values():
        state = es.random_state(rng, deformation=regime)
        reference = rng.normal(size=25)
        reference[18] *= 0.1
        _check_reference_derivatives(kernels, state, reference, rng.normal(size=14), rng.normal(size=14),
                                     rng.normal(size=3) * 9.81)


# ---------------------------------------------------------------------------------------------- whole runs
import yaml  # noqa: E402

import latdyn  # noqa: E402
from latdyn.errors import SceneError  # noqa: E402
from test_sensitivities_transient import _run  # noqa: E402
from tests.cli_runs import latdyn_run  # noqa: E402

CANTILEVER = """
title: planar cantilever, its tip body's position the parameter L
parameters: {L: 2.0, P: 50.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: ["L", 0, 0]}
sections:
  s: {EA: 1.0e7, EIy: 2.0e4, EIz: 2.0e4, GJ: 1.5e4, rhoA: 0}
beams:
  arm: {from: base, to: tip, section: s, elements: 4}
loads:
  - {at: tip, force: [0, "-P", 0]}
solve: {analysis: static, method: load-control, steps: 2, sensitivities: [L]}
output:
  probes:
    tip_y: {point: tip, quantity: position, component: y}
    tip_x: {point: tip, quantity: position, component: x}
    tip_dy: {point: tip, quantity: displacement, component: y}
    tip_d: {point: tip, quantity: displacement, component: norm}
"""

KNEE_3D = """
title: two beams at an angle under gravity, hinged at the knee; the knee's position, the hinged beam's offset
  and its free end are parameters
gravity: [0, 0, -9.81]
parameters: {X: 1.0, Y: 0.1, tz: 0.4, dy: 0.05, F: 2.0}
sections:
  s: {EA: 1.0e4, EIy: 20.0, EIz: 30.0, GJ: 15.0, rhoA: 0.5, rhoIy: 0.005, rhoIz: 0.01}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: ["X", "Y", 0], mass: 0.8, com: [0.05, 0, -0.05], inertia: [0.01, 0.01, 0.02]}
beams:
  a: {from: base, to: knee, section: s, elements: 2, y_axis: [0, 1, 0]}
  b:
    from: {body: knee, offset: [0, "dy", 0]}
    to: [1.6, 0.5, "tz"]
    section: s
    elements: 2
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: 30.0, damping: 0.2, rest_angle: 0.1}}
loads:
  - {at: b.end, force: ["0.3*F", "-F", "0.5*F"]}
  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}
solve: {analysis: transient, dt: 0.005, t_end: 0.04, sensitivities: [X, Y, tz, dy]}
output:
  every: 0.01
  probes:
    tip_x: {point: b.end, quantity: position, component: x}
    tip_y: {point: b.end, quantity: position, component: y}
    tip_z: {point: b.end, quantity: position, component: z}
    tip_d: {point: b.end, quantity: displacement, component: norm}
    root_z: {point: b.start, quantity: displacement, component: z}
    hinge: {hinge: b.start, quantity: angle}
"""

#: a 3D cantilever with a free end whose y coordinate is the parameter L, its section's axes oblique
FREE_END_3D = """
title: 3D cantilever to a free end [0.4, L, 0.3]
parameters: {L: 1.5}
sections:
  s: {EA: 1.0e6, EIy: 40.0, EIz: 90.0, GJ: 30.0, rhoA: 0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: base, to: [0.4, "L", 0.3], section: s, elements: 3, y_axis: [1, 0, 1]}
loads:
  - {at: arm.end, force: [3.0, 0.5, -4.0], moment: [0.2, 0, 0.5]}
solve: {analysis: static, method: load-control, steps: 2, sensitivities: [L]}
output:
  probes:
    end_x: {point: arm.end, quantity: position, component: x}
    end_y: {point: arm.end, quantity: position, component: y}
    end_z: {point: arm.end, quantity: displacement, component: z}
"""


#: KNEE_3D static under gravity (beams with mass: the gravity load's derivative by the reference data)
STATIC_KNEE_3D = (KNEE_3D.replace("solve: {analysis: transient, dt: 0.005, t_end: 0.04,",
                                  "solve: {analysis: static, method: load-control, steps: 3,")
                  .replace('"-2*F*t"', '"-2*F"').replace("  every: 0.01\n", ""))

#: a planar hinged arm under gravity whose fixed base (a fixed end's reference point) and tip body move
PLANAR_SWING = """
title: planar hinged arm, its fixed base and its tip body moved
parameters: {yb: 0.1, L: 1.0, P: 3.0}
gravity: [0, -9.81, 0]
sections:
  s: {EA: 1.0e4, EIy: 5.0, EIz: 5.0, GJ: 4.0, rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.001}
bodies:
  base: {at: [0, "yb", 0], fixed: true}
  tip: {at: ["L", 0.2, 0], mass: 0.4, inertia: [0.02, 0.02, 0.02]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: 8.0, damping: 0.3}}
loads:
  - {at: tip, force: ["0.2*P*t", "-P*t", 0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.1, sensitivities: [yb, L]}
output:
  every: 0.05
  probes:
    tip_y: {point: tip, quantity: displacement, component: y}
    tip_x: {point: tip, quantity: position, component: x}
    mid_y: {point: "arm.node[1]", quantity: position, component: y}
    hinge: {hinge: arm.start, quantity: angle}
"""

def _richardson(text: str, name: str, relative_step: float, landed: bool = False) -> dict:
    """d(probe)/d(name) over the rows by Richardson-extrapolated central differences of whole runs (the
    perturbation varied, the step fixed), as tests/test_sensitivities_transient.py's ``_richardson`` but with
    the step ``relative_step`` |p| (its 1e-2 leaves a truncation of 8e-7 on the knee's position here);
    ``landed``: the runs ask for the sensitivity by ``name`` too, so that their steps land on an event to 1e-12
    (without, to 1e-7: the differences' error through a compliant stop's onset was 0.15)."""
    data = yaml.safe_load(text)
    if landed:
        data["solve"]["sensitivities"] = [name]
    else:
        del data["solve"]["sensitivities"]
    plain = yaml.safe_dump(data)
    p0 = data["parameters"][name]
    h = relative_step * abs(p0)
    central = []
    for step in (h, h / 2):
        up, down = _run(plain, **{name: p0 + step}), _run(plain, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        central[-1]["load_factor"] = (up.t - down.t) / (2 * step)   # a static path's rows: the load factor
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


def _agree(result, text: str, name: str, tolerance: float, relative_step: float = 3e-3, landed: bool = False) -> float:
    """The largest error of ``result``'s sensitivities by ``name`` against :func:`_richardson`, relative to
    each probe's largest sensitivity; asserted ≤ ``tolerance``."""
    worst = 0.0
    for probe, expected in _richardson(text, name, relative_step, landed).items():
        if probe == "load_factor" and (probe, name) not in result.sensitivities:
            continue   # the load factor is a result under displacement control only
        scale = np.abs(expected).max()
        if scale < 1e-12:   # a probe the parameter does not move (a displacement's start)
            assert np.abs(result.sensitivities[(probe, name)]).max() < 1e-12, (probe, name)
            continue
        error = np.abs(result.sensitivities[(probe, name)] - expected).max() / scale
        assert error <= tolerance, (probe, name, error)
        worst = max(worst, error)
    return worst


def test_planar_cantilever_by_its_length():
    """The tip body's ``at: [L, 0, 0]``: the row at λ = 0 is the moved start (δx = 1, δy = 0), the tip's
    deflection P L³/3EI has the slope P L²/EI (the beam theory's, to the element's geometric nonlinearity),
    and every row agrees with Richardson differences of whole runs (measured 2e-10)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(CANTILEVER)))
    assert result.sensitivities[("tip_x", "L")][0] == 1.0 and result.sensitivities[("tip_y", "L")][0] == 0.0
    assert result.sensitivities[("tip_dy", "L")][0] == 0.0
    P, L, EI = 50.0, 2.0, 2.0e4
    assert abs(result.probes["tip_y"][-1] + P * L ** 3 / (3 * EI)) < 1e-3 * P * L ** 3 / (3 * EI)
    assert abs(result.sensitivities[("tip_y", "L")][-1] + P * L ** 2 / EI) < 1e-3 * P * L ** 2 / EI
    assert _agree(result, CANTILEVER, "L", 1e-6) <= 1e-6


@pytest.fixture(scope="module")
def knee_3d():
    return latdyn.run(latdyn.load_scene(yaml.safe_load(KNEE_3D)))


@pytest.mark.parametrize("name", ["X", "Y", "tz", "dy"])
def test_3d_transient_by_the_knee_the_free_end_and_the_offset(knee_3d, name):
    """A genuinely 3D transient (two beams at an angle, a hinge whose axis lies in no coordinate plane, a
    joint body with inertia, rotary inertia, gravity): the knee body's position (X, Y), the hinged beam's
    free end (tz) and its offset from the knee (dy), against Richardson differences of whole runs
    (measured 1e-8 … 1.3e-8 of each probe's largest sensitivity)."""
    assert _agree(knee_3d, KNEE_3D, name, 1e-6) <= 1e-6


#: KNEE_3D spinning at t = 0 about a skew axis: the start's velocities move with the points, δv_0 = ω × δX
KNEE_SPINNING = KNEE_3D.replace("solve: {analysis: transient",
                                "initial_velocity: {angular: [0.5, -0.3, 2.0]}\nsolve: {analysis: transient")


@pytest.mark.parametrize("name", ["X", "tz", "dy"])
def test_3d_transient_spinning_at_the_start(name):
    """The knee scene with an initial rigid spin (measured 2.0e-8, 1.0e-8, 3.5e-9)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(KNEE_SPINNING)))
    assert _agree(result, KNEE_SPINNING, name, 1e-6) <= 1e-6


#: KNEE_3D with its base's motion prescribed (a translation: x = at + translation(t)) and its at moved
KNEE_SHAKEN = (KNEE_3D.replace("base: {at: [0, 0, 0], fixed: true}",
                               'base: {at: [0, "yb", 0], motion: {translation: [0, "0.05*sin(20*t)", "0.02*t*t"]}}')
               .replace("parameters: {X: 1.0,", "parameters: {yb: 0.1, X: 1.0,")
               .replace("sensitivities: [X, Y, tz, dy]", "sensitivities: [yb, X]"))


def test_3d_transient_with_a_prescribed_translation():
    """The knee scene shaken at its base (a prescribed translation), the base's ``at`` and the knee's moved
    (measured 2.1e-9, 1.4e-8)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(KNEE_SHAKEN)))
    for name in ("yb", "X"):
        assert _agree(result, KNEE_SHAKEN, name, 1e-6) <= 1e-6


def test_3d_transient_from_rest_without_rotary_inertia():
    """tests/test_sensitivities_transient.py's arm from rest without rotary inertia (the beams' twist has none:
    the start's accelerations from the directions with and without inertia), its knee moved (measured 3.3e-9)."""
    from test_sensitivities_transient import FROM_REST_3D

    text = (FROM_REST_3D.replace("knee: {at: [1, 0, 0]", 'knee: {at: ["X", 0, 0]')
            .replace("parameters: {F: 2.0,", "parameters: {X: 1.0, F: 2.0,")
            .replace("sensitivities: [F, k, c, th0, EI, G, rho, m, cx, J]", "sensitivities: [X]"))
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert _agree(result, text, "X", 1e-6) <= 1e-6


def test_3d_static_free_end():
    """A 3D cantilever to the free end [0.4, L, 0.3], its section axes oblique (y_axis [1, 0, 1]: the frame's
    turn through Gram–Schmidt), loaded by a force and a moment at the end."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(FREE_END_3D)))
    assert _agree(result, FREE_END_3D, "L", 1e-6) <= 1e-6


@pytest.mark.parametrize("text, names", [(STATIC_KNEE_3D, ["X", "Y", "tz", "dy"]), (PLANAR_SWING, ["yb", "L"])],
                         ids=["static_3d_under_gravity", "planar_transient"])
def test_static_3d_under_gravity_and_planar_transient(text, names):
    """The knee scene static under gravity, its beams with mass (the gravity load's derivative by the
    reference data; measured 4e-12 … 6e-11), and a planar transient whose fixed base and tip body move (a
    fixed end's reference point, a hinged end's frame; measured 6.5e-11, 1.7e-9)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    for name in names:
        assert _agree(result, text, name, 1e-6) <= 1e-6

#: FREE_END_3D under displacement control of its end along (0.6, 0, −0.8): the load factor moves with L
FREE_END_CONTROLLED = FREE_END_3D.replace(
    "method: load-control, steps: 2,",
    "method: displacement-control, steps: 3, control: {point: arm.end, direction: [0.6, 0, -0.8], to: 0.05},")


#: FREE_END_3D with its y_axis [1, w, 1] the parameter: the section's axes turn about the beam
FREE_END_TURNED = FREE_END_3D.replace("parameters: {L: 1.5}", "parameters: {L: 1.5, w: 0.2}").replace(
    "y_axis: [1, 0, 1]", 'y_axis: [1, "w", 1]').replace("sensitivities: [L]", "sensitivities: [w, L]")


#: KNEE_3D with the hinged beam's y_axis [w, 0, 1] the parameter (its section axes turn behind the hinge)
KNEE_TURNED = (KNEE_3D.replace("y_axis: [0, 0, 1]", 'y_axis: ["w", 0, 1]')
               .replace("parameters: {X: 1.0,", "parameters: {w: 0.3, X: 1.0,")
               .replace("sensitivities: [X, Y, tz, dy]", "sensitivities: [w]"))


@pytest.mark.parametrize("text, names", [(FREE_END_TURNED, ("w", "L")), (KNEE_TURNED, ("w",))],
                         ids=["static_free_end", "transient_knee"])
def test_3d_y_axis(text, names):
    """A beam's ``y_axis`` as a parameter (through the loader's normalisation and Gram–Schmidt): the free-end
    cantilever's ``[1, w, 1]`` and its end with it (measured 6.3e-10, 1.0e-11), the knee's hinged beam's
    ``[w, 0, 1]`` in the transient (2.9e-9)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    for name in names:
        assert _agree(result, text, name, 1e-6) <= 1e-6


def _loaded_at_the_offset(text: str) -> str:
    """``text`` (the knee scene) with a global load and one turning with the knee at b.start, the moved offset."""
    return (text.replace("loads:\n", "loads:\n"
                                      "  - {at: b.start, force: [\"0.5*F\", 0, \"-F\"], moment: [0, \"0.2*F\", 0]}\n"
                                      "  - {at: b.start, force: [0, 0, 1.5], frame: knee}\n")
            .replace("sensitivities: [X, Y, tz, dy]", "sensitivities: [dy]"))


@pytest.mark.parametrize("base", [KNEE_3D, STATIC_KNEE_3D], ids=["transient", "static_under_gravity"])
def test_3d_loads_at_a_moved_offset(base):
    """Loads at the hinged beam's start, whose offset from the knee is the parameter: ``point_load`` is linear
    in its offset, so its derivative along δr is point_load(δr) − point_load(0) (measured 3.1e-9 transient,
    2.4e-10 static)."""
    text = _loaded_at_the_offset(base)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert _agree(result, text, "dy", 1e-6) <= 1e-6


def _hinge_axis_scene(text: str) -> str:
    """``text`` (the knee scene) with its hinge axis [0, ay, 0.8] the parameter."""
    return (text.replace("axis: [0, 0.6, 0.8]", 'axis: [0, "ay", 0.8]')
            .replace("parameters: {X: 1.0,", "parameters: {ay: 0.6, X: 1.0,")
            .replace("sensitivities: [X, Y, tz, dy]", "sensitivities: [ay]"))


@pytest.mark.parametrize("base", [KNEE_3D, STATIC_KNEE_3D], ids=["transient", "static_under_gravity"])
def test_3d_hinge_axis(base):
    """The knee's hinge axis [0, ay, 0.8] (made unit by the loader): the element's global axis and its nodal
    frame turned through exp(θ skew a) (measured 2.0e-9 in the transient, the hinge turning by 0.06 rad;
    1.4e-10 static)."""
    text = _hinge_axis_scene(base)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert np.abs(result.probes["hinge"]).max() > 0.05
    assert _agree(result, text, "ay", 1e-6) <= 1e-6


def test_3d_displacement_control_moves_the_load_factor():
    """Under displacement control the controlled displacement d·(x + T r − x_0 − r_0) is held, its start moved by
    L too: the end's sensitivities and the load factor's against Richardson differences (measured 2.8e-10)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(FREE_END_CONTROLLED)))
    assert ("load_factor", "L") in result.sensitivities and np.abs(result.sensitivities[("load_factor", "L")]).max() > 0
    assert _agree(result, FREE_END_CONTROLLED, "L", 1e-6) <= 1e-6


def test_objectivity_of_a_rigidly_turned_cantilever():
    """The cantilever turned rigidly (x → u, y → w): its tip's sensitivities by L are the turned ones."""
    u, w = np.array([0.48, 0.6, 0.64]), np.array([0.8, 0.0, -0.6])
    turn = np.column_stack([u, w, np.cross(u, w)])
    base = CANTILEVER.replace("EIz: 2.0e4", "EIz: 3.0e4").replace("steps: 2", "steps: 1")
    probes = ("    tip_x: {point: tip, quantity: position, component: x}\n"
              "    tip_y: {point: tip, quantity: position, component: y}\n"
              "    tip_z: {point: tip, quantity: position, component: z}\n")
    plain = base.split("  probes:\n")[0] + "  probes:\n" + probes
    turned = (plain.replace('["L", 0, 0]', '["0.48*L", "0.6*L", "0.64*L"]')
              .replace('[0, "-P", 0]', '["-0.8*P", 0, "0.6*P"]')
              .replace("elements: 4}", "elements: 4, y_axis: [0.8, 0, -0.6]}"))
    first, second = (latdyn.run(latdyn.load_scene(yaml.safe_load(text))) for text in (plain, turned))
    d = np.array([first.sensitivities[(f"tip_{c}", "L")][-1] for c in "xyz"])
    e = np.array([second.sensitivities[(f"tip_{c}", "L")][-1] for c in "xyz"])
    assert np.abs(e - turn @ d).max() <= 1e-9 * np.abs(d).max()


def test_cli_writes_the_geometry_sensitivities(tmp_path):
    """Through the CLI: sensitivities.csv holds the tip's derivative by L, as the API computes it."""
    completed, out = latdyn_run(tmp_path, CANTILEVER, quiet=True)
    assert completed.returncode == 0, completed.stderr
    lines = (out / "sensitivities.csv").read_text().splitlines()
    header = lines[0].split(",")
    row = dict(zip(header, map(float, lines[-1].split(","))))
    expected = latdyn.run(latdyn.load_scene(yaml.safe_load(CANTILEVER))).sensitivities[("tip_y", "L")][-1]
    assert abs(row["tip_y/L"] - expected) <= 1e-12 * abs(expected)


@pytest.mark.parametrize("change, key, words", [
    (("elements: 4}", 'elements: 4, y_axis: [0, 1, "L"]}'), "solve.sensitivities",
     "beams.arm.y_axis in a planar model"),
    (("method: load-control", "method: arc-length"), "solve.sensitivities", "not arc-length"),
    (('tip: {at: ["L", 0, 0]}', 'tip: {at: ["L", 0, "L - 2"]}'), "solve.sensitivities", "off the plane"),
])
def test_refusals(change, key, words):
    """What is not differentiated is refused, naming the key and why: a y_axis parameter in a planar model, arc
    length, a planar model's point moved off its plane."""
    text = CANTILEVER.replace(*change)
    with pytest.raises(SceneError) as raised:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert raised.value.key == key and words in str(raised.value)


def test_a_prescribed_rotation_refuses_geometry_parameters():
    """A prescribed rotation carries velocities into the structure that move with its points: refused."""
    text = KNEE_3D.replace("base: {at: [0, 0, 0], fixed: true}",
                           'base: {at: [0, 0, 0], motion: {rotation: {axis: [0, 0, 1], angle: "0.5*t*t"}}}')
    with pytest.raises(SceneError) as raised:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert raised.value.key == "solve.sensitivities" and "bodies.base.motion.rotation" in str(raised.value)


def test_the_adjoint_takes_geometry_parameters(knee_3d):
    """Refused on 86d57d9 (naming solve.sensitivity_method); now the forward method's end, max and min derivatives to
    1.5e-13 of each output's largest (measured; tests/test_adjoint_geometry.py has the adjoint's own cases)."""
    text = KNEE_3D.replace("sensitivities: [X, Y, tz, dy]}",
                           "sensitivities: [X, Y, tz, dy], sensitivity_method: adjoint}")
    assert text != KNEE_3D
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(text))).summary["probe_sensitivities"]
    forward = knee_3d.summary["probe_sensitivities"]
    for probe, outputs in forward.items():
        for which, by_name in outputs.items():
            f = np.array(list(by_name.values()))
            a = np.array([adjoint[probe][which][name] for name in by_name])
            assert np.abs(a - f).max() <= 1e-10 * np.abs(f).max(), (probe, which)


# ---------------------------------------------------------------------------------------------- through events
import test_sensitivities_contact as contact  # noqa: E402
import test_sensitivities_events as events  # noqa: E402

#: tests/test_sensitivities_events.py's planar latch with its tip body's position the parameter L
LATCH_BY_LENGTH = (events.LATCH_PLANAR.replace("parameters: {k: 2.0,", "parameters: {L: 1.0, k: 2.0,")
                   .replace("tip: {at: [1.0, 0, 0]", 'tip: {at: ["L", 0, 0]')
                   .replace("sensitivities: [k, c, EI, rho, m]", "sensitivities: [L]"))
#: its 3D wheel bouncing off a stop with restitution 0.5, the wheel's position moved out along the arm
STOP_BY_PLACE = (events.STOP_3D.replace("parameters: {k: 1.0,", "parameters: {sc: 1.0, k: 1.0,")
                 .replace("wheel: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666]",
                          'wheel: {at: ["0.6666666666666666*sc", 0.3333333333333333, "0.6666666666666666*sc"]')
                 .replace("sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [sc]"))


@pytest.mark.parametrize("text, name", [(LATCH_BY_LENGTH, "L"), (STOP_BY_PLACE, "sc")], ids=["planar_latch", "3d_stop"])
def test_through_a_latch_and_a_stop(text, name):
    """"How does the latch shock change if I move this joint": a planar arm latching, its tip body's position
    moved (measured 2.5e-9; the event time to 1e-7: δt_latch = 0.509 per unit L), and a 3D wheel bouncing off its
    stop with restitution 0.5, moved along the arm (measured 1.4e-8), against tests/test_sensitivities_events.py's
    Richardson differences (their perturbation 1e-4 relative keeps the event in its step), event times included."""
    result = events._run(text)
    assert len(result.summary["event_sensitivities"]) == 1
    assert events._agree(result, text, name) <= 1e-6


#: tests/test_sensitivities_contact.py's wheel driven into a compliant stop (Hunt–Crossley), moved along its arm
CONTACT_BY_PLACE = (contact.WHEEL.replace("parameters: {kc: 300.0,", "parameters: {sc: 1.0, kc: 300.0,")
                    .replace("wheel: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666]",
                             'wheel: {at: ["0.6666666666666666*sc", 0.3333333333333333, "0.6666666666666666*sc"]')
                    .replace("sensitivities: [kc, nc, cc, k]", "sensitivities: [sc]"))


def test_through_a_compliant_stop():
    """The wheel through its compliant stop's onset (landed on) and release, moved along the arm (measured
    3.0e-9 of each probe's largest sensitivity, the reference runs landing as this one does)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(CONTACT_BY_PLACE)))
    assert result.probes["angle"].max() > 0.06   # into the stop, past its limit 0.02
    assert _agree(result, CONTACT_BY_PLACE, "sc", 1e-6, relative_step=1e-4, landed=True) <= 1e-6


#: a planar arm on a hinge spring latching at 0.05 rad, pushed by a load in t, its tip body placed at [L, 0, 0]
LATCHING_BY_PLACE = """
title: planar arm latching, pushed by a load in t, its tip placed by L
parameters: {L: 1.0, k: 2.0}
sections:
  s: {EA: 1.0e4, EIy: 20.0, EIz: 20.0, GJ: 10.0, rhoA: 0.5, rhoIy: 0.0005, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: ["L", 0, 0], mass: 0.3, inertia: [0.01, 0.01, 0.01]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: "k", damping: 0.05, rest_angle: 2.0, lock_at: 0.05}}
loads:
  - {at: tip, force: [0, "0.4*sin(6*t)", 0]}
solve: {analysis: transient, dt: 0.02, t_end: 0.3, sensitivities: [L, k]}
output:
  every: 0.02
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    tip_y: {point: tip, quantity: position, component: y}
"""


def test_a_geometry_parameter_through_a_latch_with_a_load_in_t():
    """A latch moves the later steps' ends in time, so ∂r/∂t enters (ExplicitTime: the parameters' machinery
    with the one column t); with a geometry parameter that machinery took the start's k columns along and
    raised IndexError (a traceback, on main before this session too; found in review). Against Richardson
    differences of whole runs (landed on the latch): measured 7.9e-11 (tip_x), 2.0e-9 (tip_y)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(LATCHING_BY_PLACE)))
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert _agree(result, LATCHING_BY_PLACE, "L", 1e-6, relative_step=1e-4, landed=True) <= 1e-6
