"""The hinges' part of an event's impulse weight derivative H = ∂(W w)/∂q, exact (latdyn/analyses/weight_derivative.py,
docs/parameters.md "The impulse weight's derivative"): the generated ``hinge_stiffness_by_angle`` (codegen/joints.py)
against central differences of ``hinge_force``'s ∂f/∂θ with the laws moved along the angle, in and out of a compliant
stop; a hinge's diagonal of H against SymPy's ∂²f/∂θ² of the scene's own laws on the genuinely 3D wheel of the event
tests with a nonlinear spring, damper and torque and a compliant stop (no difference along the hinge's angle left);
the whole H against Richardson-extrapolated central differences of W w; and a run through the latch against
Richardson differences of whole runs."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
import yaml

import latdyn
from latdyn.analyses.weight_derivative import _hinge_part, rest_support
from latdyn.assembly.prepare import prepare
from latdyn.model.kernels import load_kernels
from latdyn.scene.expressions import HingeLaw
from tests.sensitivity_equality import runs_with_the_loop_on_and_off
from tests.test_sensitivities_events import LATCH_3D, _agree
from tests.test_weight_derivative import _check_model

STIFFNESS, DAMPING, TORQUE = "k*(1 + 0.5*sin(2*theta))", "c*(1 + theta**2)", "0.3*cos(theta)"
#: the wheel of the event tests (3D, out of the coordinate planes) on a spring, damper and torque nonlinear in θ,
#: with a compliant lower stop (Hunt–Crossley, n = 1.5) beside its latch
WHEEL_LAWS = (LATCH_3D.replace('stiffness: "k", damping: "c"',
                               f'stiffness: "{STIFFNESS}", damping: "{DAMPING}", torque: "{TORQUE}"')
              .replace("lock_at: 0.5", "lock_at: 0.5, limits: [-0.2, 2.0], "
                                       "contact: {stiffness: 50.0, exponent: 1.5, damping: 0.5}"))


def _by_angle_numeric(kernels, theta, rate, laws, contact, h=1e-5):
    """Richardson-extrapolated central differences of hinge_force's ∂f/∂θ along θ, the laws (HingeLaw) evaluated
    at the moved angle."""
    def stiffness(x):
        row = np.array([[f(x, rate, 0.0) for law in laws for f in (law.value, law.d_theta, law.d_rate)]])
        return float(np.asarray(kernels.hinge_force(np.array([[x, rate, 0.3, 1.0]]), row, contact[None])[1]).ravel()[0])

    central = [(stiffness(theta + e) - stiffness(theta - e)) / (2 * e) for e in (h, h / 2)]
    return (4 * central[1] - central[0]) / 3


@pytest.mark.parametrize("theta", [-0.35, -0.201, 0.4, 2.3], ids=["lower_contact", "near_contact", "free", "upper"])
@pytest.mark.parametrize("exponent", [1.0, 1.5, 2.5])
def test_the_generated_stiffness_by_angle_is_the_central_difference_of_the_hinge_stiffness(theta, exponent):
    """``hinge_stiffness_by_angle`` at random rates against central differences of ``hinge_force``'s ∂f/∂θ
    (measured ≤ 1.1e-9 relative; out of contact the stop adds exactly 0, finite for every n ≥ 1)."""
    kernels = load_kernels("auto", "default")
    laws = [HingeLaw("2*(1 + 0.5*sin(2*theta)) + 0.1*theta_dot*theta"), HingeLaw("0.05*(1 + theta**2)"),
            HingeLaw("0.3*cos(theta)")]
    contact = np.array([-0.2, 2.0, 50.0, exponent, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    rng = np.random.default_rng(34)
    for rate in rng.normal(size=3):
        row = np.array([[f(theta, rate, 0.0) for law in laws for f in (law.value, law.d_theta, law.d_rate)]])
        curvatures = np.array([[_second(law.source, theta, rate) for law in laws]])
        exact = float(np.asarray(kernels.hinge_stiffness_by_angle(np.array([[theta, rate, 0.3, 1.0]]), row, curvatures,
                                                                  contact[None])[0]).ravel()[0])
        assert np.isfinite(exact)
        numeric = _by_angle_numeric(kernels, theta, rate, laws, contact)
        assert abs(exact - numeric) <= 1e-7 * max(abs(numeric), 1.0)


def _second(source: str, theta: float, rate: float) -> float:
    """∂²f/∂θ² of a law's text by SymPy, independently of the package."""
    th, r = sp.symbols("theta theta_dot")
    return float(sp.diff(sp.sympify(source, locals={"theta": th, "theta_dot": r}), th, 2).subs({th: theta, r: rate}))


def _reference_diagonal(theta, rate, k=1.0, c=0.05, rest=1.0, lo=-0.2, kc=50.0, n=1.5, cc=0.5):
    """∂K/∂θ, K = ∂f/∂θ, of the wheel's hinge by SymPy from the scene's text, in contact with its lower stop."""
    th, r = sp.symbols("theta theta_dot")
    names = {"theta": th, "theta_dot": r, "k": k, "c": c}
    f = (sp.sympify(STIFFNESS, locals=names) * (th - rest) + sp.sympify(DAMPING, locals=names) * r
         - sp.sympify(TORQUE, locals=names) - (lo - th) ** n * (kc - cc * r))
    return float(sp.diff(f, th, 2).subs({th: theta, r: rate}))


def test_the_hinges_diagonal_of_h_is_sympys_second_derivative_of_the_scenes_laws():
    """The wheel's hinge in contact with its compliant stop, at a turned, moving state: its part of H is s (∂K/∂θ) w
    with ∂K/∂θ SymPy's second derivative of the scene's f (measured 1.6e-16 relative; the central difference it
    replaces, along the angle with the step 1e-5 √(ℓ L_min) = 7.1e-6, was 2.5e-9 off), and H_rest takes no
    difference along the hinge's angle."""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(WHEEL_LAWS)))
    assembler, state, model = prepared.assembler, prepared.state, prepared.model
    assert len(rest_support(assembler)) == 0
    state.theta[0], state.theta_dot[0] = -0.25, 0.7
    n = model.n_dofs
    d = int(model.hinge_dofs[0])
    w = np.zeros(n)
    w[d] = 1.3
    rows, values = _hinge_part(assembler, state, w, 1e-4)
    reference = 1e-4 * 1.3 * _reference_diagonal(-0.25, 0.7)
    assert list(rows) == [d]
    assert abs(values[0] - reference) <= 1e-13 * abs(reference)


def test_h_of_the_wheel_with_nonlinear_laws_and_a_stop_is_the_central_difference_of_w_w():
    """The whole H of that wheel (elements, the wheel's mass, the hinge's laws and stop: every block generated)
    against Richardson-extrapolated central differences of the evaluation's W w along random directions (measured
    2.9e-12), with no difference left in H_rest."""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(WHEEL_LAWS)))
    assert len(rest_support(prepared.assembler)) == 0
    assert _check_model(WHEEL_LAWS.replace("limits: [-0.2, 2.0]", "limits: [0.0, 2.0]"), 9) < 1e-8


def test_a_latch_with_nonlinear_laws_through_the_cli_and_the_api_agrees_with_differences(tmp_path):
    """Through the latch (the event's H with the hinge's exact part) the sensitivities by k agree with
    Richardson-extrapolated differences of whole runs (measured 2.1e-10, as before the change: the difference's
    error on the hinge's entry, 2.5e-9 of it, lies far below the reference's), the same through the CLI."""
    from latdyn.cli import main

    text = WHEEL_LAWS.replace("limits: [-0.2, 2.0], contact: {stiffness: 50.0, exponent: 1.5, damping: 0.5}",
                              "limits: [-0.2, 2.0], contact: {stiffness: 50.0, exponent: 1.5}")
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = ["k"]
    assert len(rest_support(prepare(latdyn.load_scene(data)).assembler)) == 0   # the event's H: no difference
    result = latdyn.run(latdyn.load_scene(data))
    assert result.summary["events"]
    assert _agree(result, yaml.safe_dump(data), "k", 1e-6) < 1e-6
    scene = tmp_path / "wheel.yaml"
    scene.write_text(yaml.safe_dump(data))
    assert main(["run", str(scene), "-o", str(tmp_path / "out")]) == 0
    written = np.genfromtxt(tmp_path / "out" / "sensitivities.csv", delimiter=",", names=True)
    assert written.size > 0


def test_the_loop_of_steps_keeps_the_python_paths_bits_through_the_latch():
    """The wheel with its nonlinear laws and compliant stop, sensitivities by k and c: the loop of steps on and off
    give the same sensitivities to the bit (the latch's H, exact now, is the Python path's on both), with steps in
    the loop."""
    data = yaml.safe_load(WHEEL_LAWS)
    data["solve"]["sensitivities"] = ["k", "c"]
    runs = runs_with_the_loop_on_and_off(data)
    native, python = runs[True], runs[False]
    assert native.summary["event_sensitivities"] and native.summary["event_sensitivities"][0]["kind"] == "latch"
    assert native.summary["sensitivity_steps_in_loop"] > 0 == python.summary["sensitivity_steps_in_loop"]
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


@pytest.mark.parametrize("stiffness, exact", [("g*(1 + 0.5*sin(2*theta))", True), ("k*(1 + abs(theta))", True)],
                         ids=["naming_an_input", "abs"])
def test_a_law_naming_an_input_or_with_a_kink_is_generated(stiffness, exact):
    """A hinge law of θ that names an input (a number at the event, the value its law and slope read from the
    scene's inputs) and a law with a kink (abs: its slope sign(θ)) are generated
    (:func:`latdyn.analyses.weight_derivative.exact_hinges`: no difference along the angle; 10be92c differenced the
    first); H against Richardson differences of W w either way."""
    text = WHEEL_LAWS.replace(f'stiffness: "{STIFFNESS}"', f'stiffness: "{stiffness}"').replace(
        "sections:", "inputs: {g: 2.0}\nsections:", 1)
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    support = list(rest_support(prepared.assembler))
    assert support == ([] if exact else [prepared.model.hinge_dofs[0]])
    assert _check_model(text.replace("limits: [-0.2, 2.0]", "limits: [0.0, 2.0]"), 9) < 1e-8
