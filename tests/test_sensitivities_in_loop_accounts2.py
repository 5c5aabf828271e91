"""The work accounts and reels everywhere in the transient sensitivities' loop of steps (issue 34 item 2;
latdyn/analyses/sensitivities_in_loop.py ``_account_refusal``, ``model_refusal``): the runs below took every step from
Python before and now take their smooth steps in the loop, their sensitivities the Python path's (the private switch
``SENSITIVITIES_IN_LOOP`` off) to the bit, through the API and ``latdyn run``:

- reels beside other explicit time dependence and controllers (their rest-length columns of ∂r/∂t added after the hinge
  laws', the controllers' and the loads', as ExplicitTime.of_laws adds them): a 3D mast braced by three cables, one
  reeled in, pushed by a load of t, its hinge driven by a PD controller plus a torque of t, latching; the same without
  the controller with its base prescribed;
- the work accounts with laws of θ, θ̇ (a damper c (1 + θ̇²), a torque −0.1 k sin θ + 0.5 t, a spring k (1 + 0.2 θ² +
  0.1 t) whose work is external): their values compiled as the step's hinge laws (energy_sensitivities.account_laws),
  the C both paths call, evaluated in C at the hinge's θ, θ̇, t (csrc/work_accounts.c);
- the external work with a prescribed motion (the drive's δr_d = ∂r_d/∂p + K_d δq + C_d δv + M_d δv̇ and its sum
  ½ Σ Δq_d (δr_d,n + δr_d,n+1), csrc/drive_sensitivities.c on both paths): a 3D boom whose base slews about a skew axis
  and translates, and one whose inner hinge angle is prescribed;
- the external work on a model with rigid links: the 3D gimbal of rigid links carrying a flexible boom with two
  loads, one of t, and both accounts; the same with the second load on the outer ring, a node the links carry (its
  δπ, δv: δq_dep = J δq, δv_dep = J δv + ∂(J v)/∂q δq from the links' buffers, csrc/work_accounts.c
  dependent_node_motion, on both paths);
- the dissipated energy with guides: the guided mass on a damped skew guide at the tip of a flexible 3D arm (the
  Python path computes it now: the guide's damper on its slide is a hinge's on its angle).

Against Richardson central differences: the slewing boom's and the gimbal's (a load on a link) external work and
the guided mass's dissipated energy. The external work with guides: tests/test_sensitivities_guide_energies.py."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_guides import GUIDE_3D
from tests.test_sensitivities_in_loop_cables2 import MAST_PD_PUSHED
from tests.test_sensitivities_in_loop_work import BOOM_3D, _same
from tests.test_sensitivities_in_loop_work import test_the_work_accounts_take_the_loop as accounts_take_the_loop
from tests.test_sensitivities_rigid_links import GIMBAL

#: the PD mast pushed by a load of t (tests/test_sensitivities_in_loop_cables2.py), cable g1 reeled in (rest length
#: L − 0.2 t), its hinge latching at −0.05 rad (t ≈ 0.26 s)
REEL_PD_LATCH = (MAST_PD_PUSHED.replace('rest_length: "L", rhoA', 'rest_length: "L - 0.2*t", rhoA')
                 .replace('torque: "pd + 0.3*sin(9*t)"}', 'torque: "pd + 0.3*sin(9*t)", lock_at: -0.05}')
                 .replace("t_end: 0.1", "t_end: 0.3"))
#: the same without the controller (its hinge torque a law of t), its base translating in t
REEL_MOVED_LATCH = (REEL_PD_LATCH.replace('torque: "pd + 0.3*sin(9*t)", ', 'torque: "0.3*sin(9*t)", ')
                    .replace('controllers:\n  pd: {output: "Kp*(ref - ang) - Kd*om"}\n', "")
                    .replace("parameters: {Kp: 60.0, Kd: 4.0, ref: 0.05, ", "parameters: {")
                    .replace("[Kp, Kd, ref, EA", "[EA")
                    .replace("base: {at: [0, 0, 0], fixed: true}",
                             'base: {at: [0, 0, 0], motion: {translation: ["0.01*sin(5*t)", "0.005*t**2", 0]}}'))
assert "L - 0.2*t" in REEL_PD_LATCH and "lock_at: -0.05" in REEL_PD_LATCH and "t_end: 0.3" in REEL_PD_LATCH
assert "controllers" not in REEL_MOVED_LATCH and "0.005*t**2" in REEL_MOVED_LATCH and "[EA, L" in REEL_MOVED_LATCH

#: tests/test_sensitivities_in_loop_work.py's 3D boom (both accounts) with a damping law of θ̇, a torque of θ and t on
#: its inner hinge and a spring of θ and t (not conservative) on its outer one
BOOM_LAWS = (BOOM_3D.replace('damping: "c*(1 + 5*t)"', 'damping: "c*(1 + theta_dot**2)"')
             .replace("start: {hinge: {axis: [0, 0, 1], stiffness: 50.0, damping: 0.3}}",
                      'start: {hinge: {axis: [0, 0, 1], stiffness: 50.0, damping: 0.3, '
                      'torque: "-k*0.1*sin(theta) + 0.5*t"}}')
             .replace('stiffness: "k", damping', 'stiffness: "k*(1 + 0.2*theta**2 + 0.1*t)", damping'))
assert "theta_dot**2" in BOOM_LAWS and "sin(theta)" in BOOM_LAWS and "0.2*theta**2" in BOOM_LAWS

#: the 3D boom with its base slewing 0.5 t² − 0.1 t³ about a skew axis and translating (its drive's work in the
#: external work); Newton's tolerance tight for the differences
BOOM_SLEWING = BOOM_3D.replace(
    "base: {at: [0, 0, 0], fixed: true}",
    'base: {at: [0, 0, 0], motion: {translation: ["0.05*sin(3*t)", 0, "0.02*t**2"], '
    'rotation: {axis: [0.2, 0.1, 1.0], angle: "0.5*t**2 - 0.1*t**3"}}}').replace("t_end: 0.1,", "t_end: 0.1, tol: 1.0e-11,")
#: the 3D boom with its inner hinge's angle prescribed (0.4 sin 5t)
BOOM_DRIVEN_HINGE = BOOM_3D.replace("stiffness: 50.0, damping: 0.3}", 'angle: "0.4*sin(5*t)"}')
assert "0.5*t**2 - 0.1*t**3" in BOOM_SLEWING and "tol: 1.0e-11" in BOOM_SLEWING and "0.4*sin(5*t)" in BOOM_DRIVEN_HINGE

#: tests/test_sensitivities_rigid_links.py's gimbal of rigid links with a second load (of t, with a moment) on its
#: flexible boom, both accounts, by the springs, the damper, a joint body's mass, the load and the boom's EI
GIMBAL_WORK = (GIMBAL.replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [k1, k2, c2, m, P, EI]")
               .replace('  - {at: tip, force: [0, "P", "-0.5*P"]}',
                        '  - {at: tip, force: [0, "P", "-0.5*P"]}\n'
                        '  - {at: "boom.node[1]", force: ["0.3*P*sin(8*t)", 0, "0.2*P"], moment: [0, 0, "0.05*P"]}')
               + "    work: {energy: external_work}\n    lost: {energy: dissipated}\n")
#: the same, the second load on the outer ring (a node that follows the links); Newton's tolerance tight for the
#: differences
GIMBAL_LOAD_ON_A_LINK = GIMBAL_WORK.replace('at: "boom.node[1]"', "at: outer").replace("t_end: 0.3,",
                                                                                        "t_end: 0.3, tol: 1.0e-11,")
assert "sin(8*t)" in GIMBAL_WORK and "at: outer, force" in GIMBAL_LOAD_ON_A_LINK and "tol: 1.0e-11" in GIMBAL_LOAD_ON_A_LINK

#: the guided mass on its damped skew guide (tests/test_sensitivities_guides.py) by the guide's stiffness and damping,
#: the mass and EI, its dissipated energy probed; Newton's tolerance tight for the differences
GUIDED_LOST = (GUIDE_3D.replace("sensitivities: [k, m, EI, rest]", "sensitivities: [k, c, m, EI], tol: 1.0e-11")
               + "    lost: {energy: dissipated}\n")
assert "[k, c, m, EI], tol" in GUIDED_LOST


def _run(text: str, monkeypatch, in_loop: bool, only: str | None = None, **parameters):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python (by
    ``only`` alone where given, at ``parameters``)."""
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    if only is not None:
        data["solve"]["sensitivities"] = [only]
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(data))


@pytest.mark.parametrize("text", [REEL_PD_LATCH, REEL_MOVED_LATCH],
                         ids=["reel beside a PD, a load and a torque of t", "reel beside a moving base and loads of t"])
def test_reels_beside_other_time_dependence_take_the_loop(text, monkeypatch):
    """Every smooth step in the loop (all but the latch's and the landing after it), the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == ["latch"]
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - 2 > 100
    _same(native, python)


@pytest.mark.parametrize("text, probes", [
    (BOOM_LAWS, {"lost": ("c", "k"), "work": ("k", "F")}),
    (BOOM_SLEWING, {"work": ("EI", "rho", "k", "c", "F")}),
    (BOOM_DRIVEN_HINGE, {"work": ("EI", "k", "F")}),
    (GIMBAL_WORK, {"work": ("k1", "k2", "m", "P", "EI"), "lost": ("c2", "m")}),
    (GIMBAL_LOAD_ON_A_LINK, {"work": ("k1", "k2", "m", "P", "EI")}),
    (GUIDED_LOST, {"lost": ("k", "c", "m", "EI")}),
], ids=["laws of the state in both accounts", "external work, base slewing", "external work, hinge angle driven",
        "both accounts, rigid links", "a load on a node the links carry", "dissipated energy, a damped guide"])
def test_the_accounts_take_the_loop(text, probes, monkeypatch):
    """Every step in the loop, the accounts the Python path's to the bit; their columns nonzero (the check of
    tests/test_sensitivities_in_loop_work.py)."""
    accounts_take_the_loop(text, probes, monkeypatch)


def test_the_cli_writes_the_python_paths_files(tmp_path):
    """``latdyn run`` takes the loop; the same command with the switch off writes the same sensitivities.csv and
    probes.csv, byte for byte, and summary.json's sensitivities: the slewing boom (its drive, both accounts' laws)."""
    completed, out = latdyn_run(tmp_path, BOOM_SLEWING)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] == summary["steps"] == 20
    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("text, probe, name, measured", [(BOOM_SLEWING, "work", "k", 7.3e-8),
                                                         (GIMBAL_LOAD_ON_A_LINK, "work", "m", 1.6e-10),
                                                         (GUIDED_LOST, "lost", "c", 2.4e-10)],
                         ids=["slewing boom's external work by k", "gimbal's external work by m",
                              "guided mass's dissipated energy by c"])
def test_the_accounts_from_the_loop_agree_with_richardson_differences(text, probe, name, measured, monkeypatch):
    """The account from the loop against Richardson-extrapolated central differences (1e-4 and 5e-5 relative), over
    its rows, relative to its largest (measured: ``measured``)."""
    result = _run(text, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"]
    p0 = yaml.safe_load(text)["parameters"][name]
    central = []
    for step in (1e-4 * abs(p0), 5e-5 * abs(p0)):
        up, down = (_run(text, monkeypatch, True, name, **{name: p0 + sign * step}).probes[probe]
                    for sign in (1, -1))
        central.append((up - down) / (2 * step))
    expected = (4 * central[1] - central[0]) / 3
    error = np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max()
    assert error <= 10 * measured, error

