"""The external work's derivative across an event that renumbers the coordinates, without rigid links
(latdyn/analyses/energy_sensitivities.py ``external_work_after_event``; docs/parameters.md, "Energies and momenta").

The time loop evaluates a step's end again after an event that changes the count of its reactions (a latch, a stick,
a release, a joint that comes to rest on its stop or leaves it: latdyn/timeloop/loop.py ``_accept``), so that the
step's own trapezoid of the loads' power takes the power after the jump, ½ h (P_n + P⁺_{n+1}); its sensitivity moves
by ½ h (δP⁺ − δP⁻) + ½ δh (P⁺ − P⁻). On 7fbef8b only a latch took that correction: a stick, a release and a rest
(each arriving as a "stop") did not, and the work's derivative was off beside loads doing work on the moving parts.
The re-evaluated end carries the prescribed motions' reactions after the jump too (the loop's drive work takes them
from it): on 7fbef8b and heldcol's fix alike the drive's term kept δr⁻ (½ Σ_d Δq_d (δr⁺_d − δr⁻_d) since workstick).
Reference: Richardson-extrapolated central differences of whole runs, the time step fixed."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.test_sensitivities_friction import STUCK_3D, _run
from tests.test_sensitivities_guides import GUIDE_3D
from tests.test_sensitivities_sticks_beside import _richardson

#: the panel of tests/test_sensitivities_friction.py (STUCK_3D) on a skew hinge at the tip of a flexible 3D arm under
#: gravity, a hinge spring k and a sinusoidal hinge torque; point forces and moments (amplitude P) on the panel and on
#: the arm's middle node, varying in time; friction on the hinge: stuck from t = 0, released at 0.03, stuck again at 0.27, released at 0.30
STICK = (STUCK_3D.split("solve:")[0].replace(
    "a panel on a skew hinge at the tip of a flexible arm, sticking and slipping by friction",
    "a braked panel at the tip of a flexible 3D arm, loads doing work on the moving panel and arm").replace(
    "m: 1.0}", "m: 1.0, k: 0.5, P: 0.8}").replace(
    'torque: "A*t", friction: {coulomb: "Fc", static: "Fs"}}}}',
    'stiffness: "k*theta", torque: "0.4*A*sin(20*t)",\n                      friction: {coulomb: "Fc", static: "Fs"}}}}')
    + """loads:
  - {at: panel, force: ["P*sin(15*t)", "0.5*P", "-P*cos(10*t)"], moment: ["0.3*P", "-0.2*P*sin(12*t)", 0.1]}
  - {at: "arm.node[1]", force: [0, "P*cos(9*t)", "0.4*P"], moment: [0, 0, "0.05*P*sin(11*t)"]}
solve: {analysis: transient, t_end: 0.32, dt: 0.01, tol: 1.0e-11, sensitivities: [Fc]}
output:
  probes:
    rate: {hinge: arm.end, quantity: rate}
    work: {energy: external_work}
    total: {energy: total}
    kinetic: {energy: kinetic}
    strain: {energy: strain}
    potential: {energy: potential}
""")
assert "k: 0.5, P: 0.8}" in STICK and 'stiffness: "k*theta"' in STICK

#: the same arm without friction, under constant loads (the events' derivatives refuse loads in t beside the work),
#: its hinge between rigid stops with restitution 0: it lands on the lower one at t = 0.138 and rests there
REST = STICK.replace(
    'torque: "0.4*A*sin(20*t)",\n                      friction: {coulomb: "Fc", static: "Fs"}}}}',
    'torque: "-0.2*A",\n                      limits: [-0.1, 1.0], restitution: 0}}}').replace(
    'force: ["P*sin(15*t)", "0.5*P", "-P*cos(10*t)"], moment: ["0.3*P", "-0.2*P*sin(12*t)", 0.1]',
    'force: ["0.3*P", "0.5*P", "-P"], moment: ["0.3*P", "-0.2*P", 0.1]').replace(
    'force: [0, "P*cos(9*t)", "0.4*P"], moment: [0, 0, "0.05*P*sin(11*t)"]',
    'force: [0, "P", "0.4*P"], moment: [0, 0, "0.05*P"]').replace(
    "t_end: 0.32", "t_end: 0.2").replace("sensitivities: [Fc]", "sensitivities: [P]")
assert "restitution: 0}" in REST and "sin(" not in REST.split("loads:")[1]

#: the braked panel with its arm's root hinge turned by a prescribed angle 0.3 sin 8t about z (its drive's reaction
#: does work), recorded on the grid: stuck from t = 0, released at 0.04, stuck at 0.22, released at 0.24
DRIVE = STICK.replace(
    "  arm: {from: base, to: panel, section: s, elements: 2,\n",
    "  arm: {from: base, to: panel, section: s, elements: 2,\n"
    "        start: {hinge: {axis: [0, 0, 1], angle: \"0.3*sin(8*t)\"}},\n").replace(
    "t_end: 0.32", "t_end: 0.26").replace("output:\n", "output:\n  every: 0.01\n")
assert 'angle: "0.3*sin(8*t)"' in DRIVE and "every: 0.01" in DRIVE

#: each scene, the parameter and the differences' relative step (the driven panel's runs at F_c ± 1e-4 F_c and
#: ± 1e-3 F_c part from the derivative after the stick at 0.22, and from each other: a kink of the computed run there,
#: not a derivative's error; at 1e-5 and 1e-6 F_c the central differences of the angle agree with its derivative to 5
#: digits)
SCENES = {"stick": (STICK, "Fc", 1e-4), "rest": (REST, "P", 1e-4), "drive": (DRIVE, "Fc", 1e-5)}


@pytest.fixture(scope="module", params=list(SCENES))
def case(request):
    text, name, relative = SCENES[request.param]
    return request.param, _run(text), text, name, relative


def test_the_external_work_through_a_renumbering_event_agrees_with_richardson_differences(case):
    """The external work beside a stick and a release (by F_c; with a prescribed hinge too), and beside a rest on a
    rigid stop (by P), agrees with
    Richardson-extrapolated central differences (h = 1e-4 p) as closely as the energies do (fails on 7fbef8b).
    Measured: stick 1.3e-9 (7fbef8b: 1.2e-6), rest 1.2e-10 (7fbef8b: 2.9e-3), drive 4.0e-8 (7fbef8b and heldcol:
    4.9e-4); the other probes ≤ 2.9e-7 (rate, drive). Not
    run here: to t = 0.4 the stick's work by F_c 6.6e-10 (7fbef8b 6.1e-7 at h = 1e-4 and 1e-3 p: the derivative's,
    not the differences' error), P 1.1e-10 (7.3e-8), k 2.0e-8 at h = 1e-3 p (2.6e-6), m 7.4e-10 (4.9e-7); the rest's
    work by k 1.1e-7 (1.5e-2), EI 3.1e-10 (1.1e-2)."""
    label, result, text, name, relative = case
    events = [(e["kind"], round(e["t"], 3)) for e in result.summary["events"]]
    if label == "rest":
        assert events == [("stop", 0.138)], events
        assert max(abs(result.probes["rate"][15:])) == 0.0   # resting on its stop to the end
    elif label == "stick":
        rate = result.probes["rate"]
        assert list(rate[:4]) == [0.0] * 4 and list(rate[27:30]) == [0.0] * 3 and rate[30] != 0.0
    else:
        assert list(np.flatnonzero(result.probes["rate"] == 0.0)) == [0, 1, 2, 3, 22, 23]
    errors = _richardson(result, text, name, relative)
    assert errors["work"] <= (1e-6 if label == "drive" else 1e-8), errors
    assert max(errors.values()) <= 1e-6, errors


#: the arm's root hinge turned by a prescribed angle 0.3 sin 8t about z (DRIVE's) beside REST's panel: resting on its
#: rigid stop (lands at t = 0.1106), or latching at −0.02 rad in its place (at t = 0.0459)
ROOT_DRIVEN = ("  arm: {from: base, to: panel, section: s, elements: 2,\n",
               "  arm: {from: base, to: panel, section: s, elements: 2,\n"
               "        start: {hinge: {axis: [0, 0, 1], angle: \"0.3*sin(8*t)\"}},\n")
REST_DRIVEN = REST.replace(*ROOT_DRIVEN)
LATCH_DRIVEN = REST_DRIVEN.replace("limits: [-0.1, 1.0], restitution: 0}", "lock_at: -0.02}")
assert 'angle: "0.3*sin(8*t)"' in LATCH_DRIVEN and "lock_at: -0.02}" in LATCH_DRIVEN


@pytest.mark.parametrize("text", [REST_DRIVEN, LATCH_DRIVEN], ids=["rest", "latch"])
def test_the_external_work_through_a_landed_event_beside_a_prescribed_motion_stays_refused(text):
    """A guard: a step landed on an event (a latch, a stop) ends at a time that moves with the parameters, and so does
    the prescribed coordinate's increment over it, Δq_d = q_d(t_{n+1}) − q_d(t_n); the drive's work ½ (r_n + r_{n+1})
    Δq_d then moves by ½ (r_n + r_{n+1}) δΔq_d, δΔq_d = q̇_d(t_{n+1}) δt_{n+1} − q̇_d(t_n) δt_n, which
    ``external_work_step`` does not take (Δq_d "the prescribed law's, no parameter's"): refused, naming the prescribed
    angle. Measured with the refusal lifted, the work by P off Richardson-extrapolated central differences of whole
    runs (h = 1e-4 p; the latch's 1e-5 p alike) by 2.3e-2 (latch) and 0.28 (rest) of its largest, the other probes
    ≤ 1.3e-7; with that term added (an experiment, not in the package) 2.9e-6 and 2.3e-4: the term is most of what is
    missing, not all of it.
    Without a landed event nothing moves Δq_d (a stick is found at a step's end, δh = 0; cables beside the external
    work are refused: tests/test_sensitivities_refusals_lifted2.py)."""
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert info.value.key == "solve.sensitivities", info.value
    assert "events of arm.end (lock_at, limits) with the prescribed angle of arm.start" in str(info.value)


#: tests/test_sensitivities_guides.py's mass on a guide at the tip of a flexible 3D arm, the guide horizontal
#: (1, −2, 0) against friction, the arm's root hinge turned by DRIVE's prescribed angle, a constant load on the mass:
#: it slips from the start toward its spring's rest and sticks at t = 0.095
GUIDE_STICK_DRIVEN = (GUIDE_3D[:GUIDE_3D.index("  probes:\n")]
                      .replace("rest: 0.02, EI: 30.0}", "rest: 0.012, EI: 30.0, Fc: 0.3, Fs: 0.4, P: 0.5}")
                      .replace('axis: [1, -2, 2], stiffness: "k", damping: "c", rest: "rest"}}',
                               'axis: [1, -2, 0], stiffness: "k", damping: "c", rest: "rest",\n'
                               '                   friction: {coulomb: "Fc", static: "Fs"}}}')
                      .replace("  arm: {from: base, to: tip, section: s, elements: 3}\n",
                               "  arm: {from: base, to: tip, section: s, elements: 2,\n"
                               "        start: {hinge: {axis: [0, 0, 1], angle: \"0.3*sin(8*t)\"}}}\n")
                      .replace("t_end: 0.4, sensitivities: [k, m, EI, rest]}",
                               't_end: 0.4, tol: 1.0e-11, sensitivities: [Fc]}\nloads:\n  - {at: slider, force: [0, 0, "-P"]}')
                      + "  probes:\n    s_rate: {guide: slider, quantity: rate}\n    work: {energy: external_work}\n")
assert 'angle: "0.3*sin(8*t)"' in GUIDE_STICK_DRIVEN and "coulomb" in GUIDE_STICK_DRIVEN and "[Fc]" in GUIDE_STICK_DRIVEN


def test_a_guides_stick_beside_a_prescribed_motion_and_the_external_work_stays_refused():
    """A guard: a guide's slide held by friction is refused in any model with guides (its terms through the guide's
    reduction are not carried: TransientSensitivities._refuse_sticking), so beside a prescribed motion and the
    external work too; refused at the stick, naming the guide's friction."""
    with pytest.raises(SceneError, match=r"bodies\.slider\.guide\.friction: at t = 0\.095 the joint sticks in a model "
                                         r"with rigid links beside guides"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(GUIDE_STICK_DRIVEN)))
