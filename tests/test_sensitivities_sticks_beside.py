"""A joint that friction holds beside energy and momentum probes, and beside controllers with states or sampled ones
(latdyn/analyses/transient_sensitivities.py ``_refuse_what_a_held_angle_moves``; docs/parameters.md, "Friction").

While a joint is stuck its angle is no free coordinate but the held δθ the stick left (``held``): a row's energies
and momenta take it through their gradient's entry at the joint's slot, as the points and joint angles do
(``TransientSensitivities.record`` adds the held δθ to the joints' δθ, and the energies' forms c_q are on all
coordinates, the stuck joint's included: latdyn/analyses/energy_sensitivities.py ``_StateForms``); a controller's
sensors likewise (latdyn/analyses/sensitivities.py ``_sensor_derivatives``: a state's δs and a sample's δs). A
controller with states or a sampled one that drives a coordinate other than a stuck joint is still refused where a
joint sticks (its condensed terms of the held angle there are not carried); the discrete adjoint refuses the energies
and momenta beside a stick and takes the controllers (tests/test_adjoint_held_beside_controllers.py). Reference:
Richardson-extrapolated central differences of whole runs, the time step fixed."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.test_sensitivities_friction import STUCK_3D, _errors, _run

#: the braked panel of tests/test_sensitivities_friction.py (STUCK_3D: a panel on a skew hinge at the tip of a
#: flexible 3D arm under gravity, stuck from t = 0, released at 0.03, stuck again at 0.22, released at 0.23) with
#: its energies and momenta probed
ENERGIES = STUCK_3D.replace(
    '    mid_y: {point: "arm.node[1]", quantity: displacement, component: y}\n',
    '    mid_y: {point: "arm.node[1]", quantity: displacement, component: y}\n'
    "    kinetic: {energy: kinetic}\n    strain: {energy: strain}\n    potential: {energy: potential}\n"
    "    total: {energy: total}\n    px: {momentum: linear, component: x}\n"
    "    Lz: {momentum: angular, component: z}\n")

#: the braked panel under a constant torque 0.2 A (below the static level): stuck from t = 0, released by gravity at
#: 0.03, stuck again at 0.21, released at 0.23; the external work (the torque's and gravity's) and the kinetic energy
#: probed
WORK = STUCK_3D.replace('torque: "A*t"', 'torque: "0.2*A"').replace(
    "    torque: {hinge: arm.end, quantity: torque}\n",
    "    torque: {hinge: arm.end, quantity: torque}\n    work: {energy: external_work}\n"
    "    kinetic: {energy: kinetic}\n").replace("sensitivities: [Fc, EI]", "sensitivities: [Fc, A]")

#: the braked panel without its joint-force probe (refused beside controllers with states or sampled ones)
WITHOUT_TORQUE = STUCK_3D.replace("    torque: {hinge: arm.end, quantity: torque}\n", "")

#: the braked panel under a PI controller on its hinge (its state integrates the angle) beside the drive: stuck from
#: t = 0, released at 0.03, stuck again from the row at t = 0.206953 (off the grid), released at 0.22
PI = WITHOUT_TORQUE.replace("A: 1.0,", "A: 1.0, Kp: 2.0, Ki: 0.5,").replace(
    'torque: "A*t"', 'torque: "A*t + ctl"').replace(
    "solve:", "controllers:\n  ctl: {output: \"-Kp*angle - Ki*S\", states: {S: \"angle\"}}\nsolve:").replace(
    "sensitivities: [Fc, EI]", "sensitivities: [Fc, EI, Kp, Ki]")

#: the same under a sampled PD (100 Hz, zero-order hold): stuck and released four times
SAMPLED = WITHOUT_TORQUE.replace("A: 1.0,", "A: 1.0, Kp: 2.0, Kd: 0.1,").replace(
    'torque: "A*t"', 'torque: "A*t + pd"').replace(
    "solve:", "controllers:\n  pd: {output: \"-Kp*angle - Kd*rate\", rate: 100}\nsolve:").replace(
    "sensitivities: [Fc, EI]", "sensitivities: [Fc, EI, Kp, Kd]")

#: the PI reading the braked angle and pushing the panel by a load instead (a free coordinate)
PI_ON_A_LOAD = PI.replace('torque: "A*t + ctl"', 'torque: "A*t"').replace(
    "solve:", "loads:\n  - {at: panel, force: [0, 0, \"ctl\"]}\nsolve:")


@pytest.fixture(scope="module")
def energies():
    return _run(ENERGIES)


@pytest.mark.parametrize("name", ["Fc", "EI"])
def test_a_braked_arms_energies_and_momenta_agree_with_richardson_differences(energies, name):
    """Stuck from t = 0, released, stuck and released again: the kinetic, strain, potential and total energies and
    the linear and angular momenta agree with Richardson-extrapolated central differences of whole runs (refused on
    5a68b93). Measured: Fc ≤ 1.6e-8 (Lz; kinetic 7.9e-10, strain 1.4e-9), EI ≤ 4.5e-9 (Lz; kinetic 8.1e-11,
    strain 3.5e-11) of each probe's largest; the differences at h and h/2 differ by as much. The
    held angle's term matters: without it (the stuck joint's δθ left out of the energies' δθ) the derivatives are
    off by (Fc) kinetic 3.5e-5, strain 2.6e-2, potential 2.8e-2, total 5.4e-3, px 1.4e-3, Lz 7.9e-4, (EI) kinetic
    3.0e-5, strain 6.9e-3, potential 5.8e-3, total 7.9e-2, px 8.2e-4, Lz 1.1e-3 of their largest."""
    t, rate = energies.t, energies.probes["rate"]
    held = np.round(t[(rate == 0.0) & (t > 0)], 6)
    assert list(held) == [0.01, 0.02, 0.03, 0.22, 0.23], held   # the rows while it is stuck (from t = 0)
    errors = _errors(energies, ENERGIES, name)
    assert set(errors) >= {"kinetic", "strain", "potential", "total", "px", "Lz"}, errors
    assert max(errors.values()) <= 1e-6, errors


@pytest.fixture(scope="module")
def work():
    return _run(WORK)


@pytest.mark.parametrize("name", ["Fc", "A"])
def test_the_external_work_through_sticks_agrees_with_richardson_differences(work, name):
    """The external work summed through two sticks and releases (its steps' terms while stuck: the torque's rate
    δθ̇ 0, its angle's δθ held) agrees with Richardson-extrapolated central differences (refused on 5a68b93).
    Measured: Fc work 3.7e-8 (rate 1.7e-7, torque 5.1e-7 of their largest), A work 1.9e-9 (torque 1.7e-7). (By EI the
    differences at EI − 1e-4 EI stick a step later, at 0.22: a kink of the computed run, not a derivative.)"""
    t, rate = work.t, work.probes["rate"]
    assert list(np.round(t[rate == 0.0], 6)) == [0.0, 0.01, 0.02, 0.03, 0.21, 0.22, 0.23]
    errors = _errors(work, WORK, name)
    assert max(errors.values()) <= 1e-6, errors


def _richardson(result, text: str, name: str, relative: float) -> dict:
    """{probe: the largest error of ``result``'s sensitivities by ``name`` over the rows, relative to the reference's
    largest} against central differences of whole runs at p ± h and p ± h/2 (h = ``relative`` |p|),
    Richardson-extrapolated, the time step fixed."""
    p0 = yaml.safe_load(text)["parameters"][name]
    h, central = relative * abs(p0), []
    for step in (h, h / 2):
        up, down = _run(text, name, **{name: p0 + step}), _run(text, name, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    expected = {probe: (4 * central[1][probe] - central[0][probe]) / 3 for probe in central[0]}
    return {probe: float(np.abs(result.sensitivities[(probe, name)] - e).max() / np.abs(e).max())
            for probe, e in expected.items()}


@pytest.fixture(scope="module")
def pi():
    return _run(PI)


@pytest.fixture(scope="module")
def sampled():
    return _run(SAMPLED)


#: the relative perturbation of each parameter's differences: EI's at 1e-4 is 1.2e-5 off by truncation (1.1e-8 at
#: 1e-5), Ki's at 1e-5 1.1e-5 off by noise (its effect is small: 9.0e-8 at 1e-3)
PI_STEP = {"Fc": 1e-4, "EI": 1e-5, "Kp": 1e-4, "Ki": 1e-3}


@pytest.mark.parametrize("name", ["Fc", "EI", "Kp", "Ki"])
def test_a_braked_hinge_under_a_pi_agrees_with_richardson_differences(pi, name):
    """A PI on the braked hinge, its state integrating the angle: while stuck the state's rate reads the held angle
    (δs = δθ_held: ``_sensor_derivatives`` adds it, as a probe's row does), δS carries it to the release (refused on
    5a68b93). Measured: Fc 3.3e-8, EI 1.1e-8, Kp 5.0e-8, Ki 9.0e-8 of each probe's largest. Without the held angle's
    δs the derivatives were off by Fc 5.3e-4, EI 1.9e-4, Kp 3.1e-4, Ki 1.1e-4 of their largest."""
    t, rate = pi.t, pi.probes["rate"]
    assert list(np.round(t[rate == 0.0], 3)) == [0.0, 0.01, 0.02, 0.03, 0.207, 0.21, 0.22]
    errors = _richardson(pi, PI, name, PI_STEP[name])
    assert max(errors.values()) <= 1e-6, errors


@pytest.mark.parametrize("name", ["Fc", "Kp"])
def test_a_braked_hinge_under_a_sampled_pd_agrees_with_richardson_differences(sampled, name):
    """A sampled PD (100 Hz) on the braked hinge, stuck and released four times (refused on 5a68b93). Measured: Fc
    1.4e-8, EI 2.2e-10, Kp 2.8e-8, Kd 4.8e-9 (EI and Kd not run here: ~8 s each under load). A guard of the lifted refusal more than of the held angle's term: with
    the held δθ left out of the sampled sensors' δs the derivatives here are the same to the bit (every sample while
    stuck acts on the stuck joint's reaction alone, and the first sample after each release, on the grid, replaces
    it)."""
    t, rate = sampled.t, sampled.probes["rate"]
    assert len(t[rate == 0.0]) == 12
    errors = _richardson(sampled, SAMPLED, name, 1e-4)
    assert max(errors.values()) <= 1e-6, errors


def test_a_stick_beside_a_pi_that_drives_another_coordinate_stays_refused():
    """Guard (refused on 5a68b93 too): the PI reading the braked angle drives a load on the panel, a free coordinate,
    where its condensed dy/ds would multiply the held angle — the stick (from t = 0) refused naming the joint's
    friction."""
    with pytest.raises(SceneError) as refused:
        _run(PI_ON_A_LOAD)
    assert refused.value.key == "beams.arm.end.hinge.friction"
    assert "at t = 0 " in refused.value.expected and "drive another coordinate" in refused.value.expected


def test_the_adjoint_refuses_energies_beside_a_stick():
    """Guard: the discrete adjoint does not seed an energy's or a momentum's forms of a held angle — the stick
    refused naming the joint's friction and the probe, expecting the forward method."""
    data = yaml.safe_load(ENERGIES)
    del data["output"]["probes"]["torque"]   # a joint force: refused beside a stick too, and named first
    data["solve"]["sensitivity_method"] = "adjoint"
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(data))
    assert refused.value.key == "beams.arm.end.hinge.friction"
    expected = refused.value.expected
    assert "beside probe 'kinetic'" in expected and "sensitivity_method: forward" in expected
