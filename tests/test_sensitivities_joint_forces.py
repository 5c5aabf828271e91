"""Transient sensitivities of the joint-force probes (latdyn/analyses/joint_force_sensitivities.py): a hinge's
torque and a guide's force, its law while free, the reaction while latched or prescribed.

Reference: central differences of whole runs at p ± h and p ± h/2, Richardson-extrapolated
((4 D(h/2) − D(h))/3), the perturbation varied, the time step fixed; on runs with a latch the reference runs
ask for sensitivities too (the step then lands on the event to 1e-12) and the perturbation is small (1e-4 of
p) so that the latch stays inside the same step of the grid in every perturbed run (asserted: the same event,
its time in the same interval between rows). Around the event the whole-run differences jump: the torque is
−f(θ) up to the latch and the reaction after it, so a row between the perturbed runs' event times would
difference the jump; no row lies there (asserted), and the row right after the latch (the first row, a few
milliseconds after it, of the latched phase) is compared on its own as well as with all the others.

Checked: the deploying boom's latch load (planar, examples/deploying_boom_sensitivities.py's scene) and a
planar arm latching, by the hinge spring and the masses; a 3D arm on a skew hinge whose stiffness law,
damping and rest angle name parameters (free joint), a 3D wheel latching on a skew hinge (the reaction out
of the coordinate planes), a 3D arm swung by a prescribed hinge angle under gravity (its drive torque), a 3D
compliant stop's torque (its law's parameters), a hinge a PD drives, a guide's force law, a guide latching on a flexible arm's tip
and a hinge latching beside a guide (reactions through the guides' reduction); the exact rows on constrained
coordinates against the exact matrices; the CLI's sensitivities.csv; what stays refused."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_contact import WHEEL
from tests.test_sensitivities_events import LATCH_3D, LATCH_PLANAR, _run
from tests.test_sensitivities_guides import BEAD, GUIDE_3D
from tests.test_sensitivities_transient import SWING_3D


def _with_probe(text: str, after: str, line: str) -> str:
    """``text`` with the probe ``line`` added after the probe line that starts with ``after``."""
    lines = text.splitlines(keepends=True)
    at = next(i for i, entry in enumerate(lines) if entry.strip().startswith(after))
    return "".join(lines[:at + 1] + [f"    {line}\n"] + lines[at + 1:])


#: LATCH_PLANAR with the hinge's torque, a row every step (the first row after the latch at 0.4575 s is 0.46 s)
LATCH_TORQUE = _with_probe(_with_probe(LATCH_PLANAR, "hinge:", "torque: {hinge: arm.start, quantity: torque}"),
                           "hinge:", "rate: {hinge: arm.start, quantity: rate}").replace("every: 0.05", "every: 0.01")

#: the deploying boom of examples/deploying_boom_sensitivities.py up to 0.3 s after its latch (1.099 s): the
#: hinge's torque after the latch is the latch load
BOOM = """
title: deploying two-panel boom, planar, its hinge spring and damper named, the latch load probed
parameters: {k: 2.0, c: 0.1}
sections:
  panel: {EA: 1.0e+6, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}
bodies:
  root: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0], mass: 0.2}
  tip: {at: [0, 0.05, 0], mass: 0.5}
beams:
  inner: {from: root, to: knee, section: panel, elements: 3}
  outer:
    from: {body: knee, offset: [0, 0.05, 0]}
    to: tip
    section: panel
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: "k", damping: "c", rest_angle: 3.6, lock_at: "pi"}}
solve: {analysis: transient, t_end: 1.4, dt: 0.005, rho_inf: 0.5, sensitivities: [k, c]}
output:
  every: 0.01
  probes:
    latch: {hinge: outer.start, quantity: torque}
    knee_y: {point: knee, quantity: displacement, component: y}
"""

#: a flexible arm on a skew hinge (axis (1, −2, 0)/√5) swung by a prescribed angle under gravity, a tip body
#: with its centre of mass off its node: the hinge's torque is the drive torque the motion needs
DRIVEN_3D = """
title: a flexible arm swung by a prescribed hinge angle, out of the coordinate planes
parameters: {EI: 5.0, rho: 0.4, m: 0.3}
gravity: [0, 0, -9.81]
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "1.2*EI", GJ: 3.0, rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.01*rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6, 0.3, 0.6], mass: "m", com: [0.02, 0, 0], inertia: [0.003, 0.002, 0.004]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [1, -2, 0], angle: "0.6*sin(4*t)"}}
solve: {analysis: transient, dt: 0.01, t_end: 0.5, sensitivities: [EI, rho, m]}
output:
  every: 0.05
  probes:
    drive: {hinge: arm.start, quantity: torque}
    tip_z: {point: tip, quantity: position, component: z}
"""


def _richardson(text: str, name: str, probe: str, relative: float) -> tuple[np.ndarray, list]:
    """d(probe)/d(name) over the rows by Richardson-extrapolated central differences of whole runs that ask
    for the sensitivities by ``name`` (landing on events), and the perturbed runs' events."""
    p0 = yaml.safe_load(text)["parameters"][name]
    h = relative * abs(p0)
    central, events = [], []
    for step in (h, h / 2):
        up, down = _run(text, name, **{name: p0 + step}), _run(text, name, **{name: p0 - step})
        central.append((up.probes[probe] - down.probes[probe]) / (2 * step))
        events += [up.summary["events"], down.summary["events"]]
    return (4 * central[1] - central[0]) / 3, events


def _agree(result, text: str, name: str, probe: str, relative: float = 1e-4) -> tuple[float, float]:
    """(the largest error of ``result``'s sensitivities of ``probe`` by ``name`` over the rows, that at the first
    row after the first event), relative to the probe's largest sensitivity; asserts that every perturbed run has
    the same events as ``result``, each inside the same interval between rows (module docstring)."""
    expected, events = _richardson(text, name, probe, relative)
    nominal = result.summary["events"]
    for perturbed in events:
        assert [(e["joint"], e["kind"]) for e in perturbed] == [(e["joint"], e["kind"]) for e in nominal]
        for a, b in zip(perturbed, nominal):
            assert np.searchsorted(result.t, a["t"]) == np.searchsorted(result.t, b["t"])
    scale = np.abs(expected).max()
    assert scale > 1e-9, (probe, name)
    error = np.abs(result.sensitivities[(probe, name)] - expected) / scale
    after = int(np.searchsorted(result.t, nominal[0]["t"])) if nominal else 0
    return float(error.max()), float(error[after])


def test_the_deploying_booms_latch_load_by_its_hinge_spring_agrees_with_richardson_central_differences():
    """The designer's number: how the latch load changes with the hinge spring. The torque goes from the
    spring's and damper's −k(θ − 3.6) − cθ̇ (7.2 N·m at the start, 0.43 N·m at the last row before the latch at
    1.099 s) to the reaction that holds the latch (−1.2 N·m at the next row, 0.8 ms later, −28 N·m at most);
    its derivative by k over the deployment and the latched phase measured 6.9e-9 of its largest (at the first
    row after the latch; the knee's displacement 3.1e-10; by c 6.3e-9)."""
    result = _run(BOOM, "k")
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    latched = result.t > result.summary["events"][0]["t"]
    assert np.all(result.probes["latch"][~latched] > 0) and result.probes["latch"][latched].min() < -25
    worst, after = _agree(result, BOOM, "k", "latch")
    assert worst <= 1e-7 and after <= 1e-7, (worst, after)
    # the peak latch load's derivative in summary.json probe_sensitivities: the row of the torque's minimum
    peak = int(np.argmin(result.probes["latch"]))
    assert result.summary["probe_sensitivities"]["latch"]["min"]["k"] == result.sensitivities[("latch", "k")][peak]


@pytest.fixture(scope="module")
def latch_planar():
    return _run(LATCH_TORQUE)


@pytest.mark.parametrize("name", ["k", "m"])
def test_a_planar_latch_load_by_the_spring_and_the_tip_mass_agrees_with_richardson_central_differences(
        latch_planar, name):
    """The arm's hinge latches at 0.4575 s; every row compared, the first after the latch (0.46 s) on its own
    (measured, of the largest: k 2.9e-9, at the first row after the latch 2.7e-9; m 2.1e-9, 5.1e-10; not run
    here: EI 8.3e-9, c 8.7e-8, both largest at that row)."""
    worst, after = _agree(latch_planar, LATCH_TORQUE, name, "torque")
    assert worst <= 1e-7 and after <= 1e-7, (name, worst, after)
    event = latch_planar.summary["events"][0]["t"]
    before, probes = latch_planar.t < event, latch_planar.probes   # the law −k(θ − 2) − cθ̇ before, the reaction after
    law = -2.0 * (probes["hinge"] - 2.0) - 0.05 * probes["rate"]
    np.testing.assert_allclose(probes["torque"][before], law[before], rtol=1e-12)
    assert np.all(np.abs(probes["torque"][~before] - law[~before]) > 1.0)


@pytest.mark.parametrize("name", ["k", "th0", "c", "EI"])
def test_a_free_3d_hinge_on_a_skew_axis_with_parameters_in_its_laws_agrees(name):
    """SWING_3D (a spinning 3D arm under gravity, a hinge on the axis (0, 0.6, 0.8) with the stiffness law
    k(1 + (θ − θ0)²), damping c, rest angle θ0): its torque −f(θ, θ̇; p) by the law's parameters and by the
    structure's EI, which moves it through θ alone (measured: k 4.3e-10, th0 2.7e-10, c 1.0e-9, EI 2.8e-9;
    m 1.3e-9 not run here)."""
    text = _with_probe(SWING_3D, "hinge:", "torque: {hinge: b.start, quantity: torque}")
    result = _run(text, name)
    worst, _ = _agree(result, text, name, "torque", relative=1e-2)
    assert worst <= 1e-7, (name, worst)


def test_a_3d_wheel_latching_on_a_skew_hinge_agrees():
    """The wheel of LATCH_3D latches at 1.058 s on the hinge (1, −2, 0)/√5 at the end of an arm along (2, 1, 2)/3:
    its reaction out of the coordinate planes by the wheel's inertia J (measured 9.0e-10, at the first row after
    the latch 6.4e-10; not run here: k 9.2e-10, m 2.7e-8)."""
    text = _with_probe(LATCH_3D, "angle:", "torque: {hinge: arm.end, quantity: torque}")
    result = _run(text, "J")
    worst, after = _agree(result, text, "J", "torque")
    assert worst <= 1e-7 and after <= 1e-7, (worst, after)


@pytest.mark.parametrize("name", ["m", "EI"])
def test_the_drive_torque_of_a_prescribed_3d_hinge_agrees(name):
    """The reaction of a prescribed angle (its coordinate never free): the exact rows of M, C and K on the
    hinge's coordinate along (δq, δv, δv̇) and ∂r/∂p there (measured: m 7.3e-10, EI 2.8e-10, rho 1.1e-9)."""
    result = _run(DRIVEN_3D, name)
    worst, _ = _agree(result, DRIVEN_3D, name, "drive")
    assert worst <= 1e-7, (name, worst)


def test_the_torque_of_a_compliant_stop_by_its_laws_stiffness_agrees():
    """WHEEL's hinge runs into its compliant stop and leaves it: its torque (spring, damper and Hunt–Crossley
    contact) by the contact stiffness (measured 5.8e-10; nc 8.4e-11, k 1.9e-7 at the onset not run here)."""
    text = _with_probe(WHEEL, "angle:", "torque: {hinge: arm.end, quantity: torque}")
    result = _run(text, "kc")
    worst, _ = _agree(result, text, "kc", "torque")
    assert worst <= 1e-7, worst


def test_the_torque_of_a_hinge_a_pd_drives_agrees():
    """PD_PLANAR: a continuous PD y = −6(θ − 0.1) − k_d θ̇ drives the hinge's torque; the probe −(2θ − y) moves
    through the controller's sensors (the coupling entries of the hinge's row) and explicitly with k_d (measured:
    kd 1.7e-9, P 2.8e-10; without the coupling entries 0.31 and 0.27)."""
    from tests.test_sensitivities_rates import PD_PLANAR

    text = _with_probe(PD_PLANAR, "om:", "torque: {hinge: arm.start, quantity: torque}")
    result = _run(text)
    for name in ("kd", "P"):
        worst, _ = _agree(result, text, name, "torque", relative=1e-3)
        assert worst <= 1e-7, (name, worst)


def test_the_reaction_of_a_latched_hinge_a_pd_drives_agrees():
    """PD_PLANAR's hinge latching at 0.02 rad (0.066 s; rotary inertia on the arm): after the latch the reaction
    holds the PD's torque with the rest, its row's coupling entries and the controller's ∂y/∂p in ∂r_d/∂p
    (measured: kd 5.8e-8, at the first row after the latch 8.5e-10; P 2.1e-9 not run here)."""
    from tests.test_sensitivities_rates import PD_PLANAR

    text = _with_probe(PD_PLANAR, "om:", "torque: {hinge: arm.start, quantity: torque}").replace(
        'torque: "pd"}', 'torque: "pd", lock_at: 0.02}').replace(
        "rhoA: 0.5}", "rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.001}").replace("every: 0.05", "every: 0.01")
    result = _run(text, "kd")
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    worst, after = _agree(result, text, "kd", "torque")
    assert worst <= 1e-7 and after <= 1e-7, (worst, after)


def test_a_guides_force_law_agrees():
    """The bead on the turning rod (BEAD) pushed by a force law F sin(10 t) on its slide besides its spring:
    the guide's force by F (measured 2.4e-8 of the largest; by the spring's k 3.4e-8, not run here)."""
    text = _with_probe(BEAD.replace('rest: "rest"}', 'rest: "rest", force: "F*sin(10*t)"}')
                       .replace("rest: 0.05}", "rest: 0.05, F: 0.3}")
                       .replace("sensitivities: [k, c, m, rest]", "sensitivities: [k, F]"),
                       "s: {guide", "force: {guide: bead, quantity: force}")
    worst, _ = _agree(_run(text, "F"), text, "F", "force")
    assert worst <= 1e-7, worst


#: GUIDE_3D's slider latching at s = −0.05 (0.2405 s) on its skew guide at the tip of the flexible arm
GUIDE_LATCH = _with_probe(GUIDE_3D.replace('rest: "rest"}}', 'rest: "rest", lock_at: -0.05}}').replace(
    "t_end: 0.4", "t_end: 0.3"), "s: {guide", "force: {guide: slider, quantity: force}")

#: GUIDE_3D with the arm's root hinged (a spring k2 about z, latching at 0.05 rad at 0.2444 s) beside the free guide
HINGE_BESIDE_GUIDE = _with_probe(
    GUIDE_3D.replace("arm: {from: base, to: tip, section: s, elements: 3}",
                     "arm: {from: base, to: tip, section: s, elements: 3, start: {hinge: {axis: [0, 0, 1], "
                     "stiffness: \"k2\", rest_angle: 0.5, lock_at: 0.05}}}")
    .replace("EI: 30.0}", "EI: 30.0, k2: 2.0}").replace("sensitivities: [k, m, EI, rest]", "sensitivities: [m, k2]")
    .replace("t_end: 0.4", "t_end: 0.3"),
    "s: {guide", "torque: {hinge: arm.start, quantity: torque}")


@pytest.mark.parametrize("text, probe, name", [(GUIDE_LATCH, "force", "m"), (HINGE_BESIDE_GUIDE, "torque", "k2")],
                         ids=["guide-latch-m", "hinge-latch-beside-a-guide-k2"])
def test_reactions_through_the_guides_reduction_agree(text, probe, name):
    """A held joint in a model with guides: its reaction is r_all,d + Σ J_c,dᵀ r_c through the reduction, and its
    derivative adds the wrenches' (along the dependent nodes' δq, δv, δv̇) and the generated slide_wrench's
    (measured up to 0.3 s: the guide's latch by m 8.8e-9, by EI 9.8e-9, k 1.4e-8; the hinge's latch beside the
    guide by k2 1.2e-8, m 1.9e-8; at the first row after the latch ≤ 8.3e-9)."""
    result = _run(text, name)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    worst, after = _agree(result, text, name, probe)
    assert worst <= 1e-7 and after <= 1e-7, (worst, after)


@pytest.mark.parametrize("scene", ["swing", "pd", "cable", "guide"])
def test_the_exact_rows_on_free_coordinates_are_those_of_the_exact_matrices(scene):
    """Assembler.exact_rows scatters the blocks the exact matrices are made of onto any rows: on the free
    coordinates it gives their rows (to the last bit here), on a latched hinge's the row the reaction moves with;
    the 3D arm with joint bodies (their inertia stiffness), a PD controller (its couplings), a 3D cable, and
    with guides the assembled coordinates' rows before the reduction."""
    from latdyn.assembly.linked import evaluate_linked
    from latdyn.assembly.prepare import prepare
    from tests.test_sensitivities_cables import CABLE_3D
    from tests.test_sensitivities_rates import PD_PLANAR

    text = {"swing": SWING_3D, "pd": PD_PLANAR, "cable": CABLE_3D, "guide": GUIDE_3D}[scene]
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, model = prepared.assembler, prepared.model
    state = assembler.initial_state()
    state.v[:], state.w[:], state.a[:], state.alpha[:] = 0.1, 0.2, 0.3, -0.2
    assembler.complete_links(state)
    if model.links is None:
        exact = assembler.exact_matrices(state, dense=True)
    else:
        ev = evaluate_linked(model.links, assembler, state, True, 1.0, True, inertia_tangent=True, rates_term=True)
        exact = [np.asarray(ev.combined_before_reduction(*c, True))
                 for c in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))]
    for matrix, rows in zip(exact, assembler.exact_rows(state, np.arange(model.n_assembled))):
        assert np.any(matrix)
        np.testing.assert_allclose(rows, matrix, rtol=0, atol=1e-12 * np.abs(matrix).max())


def test_the_cli_writes_the_torques_sensitivities_and_the_api_gives_the_same(tmp_path, latch_planar):
    """Through ``python -m latdyn run``: sensitivities.csv's torque columns, equal to the API's run."""
    from latdyn.results.result import Result

    run, out = latdyn_run(tmp_path, LATCH_TORQUE)
    assert run.returncode == 0, run.stderr
    header = (out / "sensitivities.csv").read_text().splitlines()[0].split(",")
    assert "torque/k" in header and "torque/m" in header
    result = Result.load(out)
    np.testing.assert_array_equal(result.sensitivities[("torque", "k")], latch_planar.sensitivities[("torque", "k")])


@pytest.mark.parametrize("change, expected", [
    (lambda t: t.replace("solve: {", "controllers: {pid: {output: \"-2*slider_z - I\", states: {I: \"slider_z\"}}}"
                                     "\nsolve: {").replace('rest: "rest"}}', 'rest: "rest", force: "pid"}}'),
     "controller 'pid' drives bodies.slider.guide.force, and controller 'pid' has states"),
    (lambda t: t.replace("solve: {", "controllers: {pd: {output: \"-2*slider_z\"}}\nsolve: {").replace(
        'rest: "rest"}}', 'rest: "rest", force: "pd"}}'), "controller 'pd' drives bodies.slider.guide.force in a model "
                                                          "with guides"),
    (lambda t: t.replace("solve: {", "controllers: {watch: {output: \"0.1*force\", rate: 100}}\nsolve: {"),
     "controller 'watch' reads the joint-force probe 'force'"),
])
def test_what_is_not_differentiated_is_refused_naming_the_key(tmp_path, change, expected):
    """A joint a controller with states drives, one a controller drives beside guides, a joint force a controller
    reads: exit 2 naming solve.sensitivities."""
    text = _with_probe(GUIDE_3D, "s: {guide", "force: {guide: slider, quantity: force}")
    run, _ = latdyn_run(tmp_path, change(text))
    assert run.returncode == 2 and "solve.sensitivities" in run.stderr and expected in run.stderr, run.stderr
    assert "Traceback" not in run.stderr


@pytest.mark.parametrize("text", ["swing", DRIVEN_3D, "pd"], ids=["3d-free-hinge-laws", "3d-prescribed-drive-torque",
                                                                 "planar-pd-driven"])
def test_the_adjoint_of_joint_forces_equals_the_forward_method(text):
    """The adjoint seeds a joint force's forms at its rows (c_q into q̄, c_v into v̄, c_v̇ into v̇̄, the explicit
    ∂/∂p into the gradient): its end, max and min equal the forward method's (measured 3.0e-15 for the free
    hinge's torque by k, c, th0, EI, m; 4.2e-15 for the prescribed hinge's drive torque by EI, rho, m, which
    without the c_v̇ seed differed by 6.4e-3; 2.4e-14 for the PD-driven hinge by kd, P)."""
    from tests.test_sensitivities_adjoint import _adjoint, _disagreement
    from tests.test_sensitivities_rates import PD_PLANAR

    if text == "swing":
        text = _with_probe(SWING_3D, "hinge:", "torque: {hinge: b.start, quantity: torque}").replace(
            "[F, k, c, th0, EI, G, rho, m, cx, J]", "[k, c, th0, EI, m]")
    elif text == "pd":
        text = _with_probe(PD_PLANAR, "om:", "torque: {hinge: arm.start, quantity: torque}")
    forward, adjoint = _run(text), _run(_adjoint(text))
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10
