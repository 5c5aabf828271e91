"""Small wrongs found in reading issue 34's code, each mended with a check through the front door (YAML text as a user
types it, ``latdyn run`` or ``latdyn.run(latdyn.load_scene(...))``).

- A cart on a skew guide held by static friction from t = 0, nothing else free (gravity's pull along the guide
  9.81·0.5/1.5 = 3.27 N, F_s = 5 N): the forward method differentiates the held cart (nothing moves; a guide force
  probe's ∂/∂m is −3.27); the adjoint refused it at t = 0 saying "a joint sticks in a model with guides or rigid links"
  (it sticks at no time, and the forward method does run it) and the forward method refused the cart's release by a
  growing push with "several joints stick or slip, or a latch, a stop or a cable's change comes, at one instant" (one
  joint was released, nothing else came): each message now says what happens and what is expected.
- A hinge's or guide's law whose slope in θ or θ̇ is not finite at the joint's start (``torque: "k*sqrt(abs(theta))"``
  at θ_0 = 0) ended in "internal error: LinAlgError: Eigenvalues did not converge" (the check of what holds the
  coordinates, with or without solve.sensitivities), ``(theta - 0.0)**(1/3)`` in the same error, and
  ``abs(theta_dot)**0.5`` in Newton's failure at the first step: each is a SceneError naming the law's key before the
  run (latdyn/assembly/prepare.py). Laws in t whose rate is infinite at t = 0 (``k*sqrt(t)``, ``k*t**0.25`` as torque,
  stiffness or damping, beside a latch, forward and adjoint) ran and run (not reproduced).
"""
from __future__ import annotations

import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run, summary_of
from tests.test_adjoint_in_loop_links import _largest_gap

#: a cart at rest on a skew guide, held there by static friction from t = 0 (its only coordinate the guide's slide)
HELD_CART = """
title: a cart at rest on a skew guide, held by static friction
parameters: {Fc: 1.0, Fs: 5.0, m: 1.0}
gravity: [0, 0, -9.81]
bodies:
  cart: {at: [0, 0, 0], mass: "m", inertia: [0.01, 0.01, 0.01],
         guide: {axis: [1, 1, -0.5], friction: {coulomb: "Fc", static: "Fs"}}}
solve: {analysis: transient, dt: 0.01, t_end: 0.1, sensitivities: [Fc, m]}
output:
  probes:
    x: {point: cart, quantity: position, component: x}
    f: {guide: cart, quantity: force}
"""


def _with(text: str, **solve) -> dict:
    data = yaml.safe_load(text)
    data["solve"].update(solve)
    return data


def test_a_cart_held_from_the_start_is_differentiated_by_the_forward_method(tmp_path):
    """Guard (passes on the base too): nothing moves, the held force is −m g·e = −3.27 m, so its ∂/∂m −3.27 and every
    other derivative 0, through ``latdyn run``."""
    completed, out = latdyn_run(tmp_path, HELD_CART, quiet=True)
    assert completed.returncode == 0, completed.stderr
    derivatives = summary_of(out)["probe_sensitivities"]
    assert derivatives["f"]["end"]["m"] == pytest.approx(-3.27, abs=1e-12)
    assert derivatives["f"]["end"]["Fc"] == 0.0 and derivatives["x"]["end"] == {"Fc": 0.0, "m": 0.0}


def test_the_adjoint_refuses_a_cart_held_from_the_start_saying_so(tmp_path):
    """The adjoint refuses it at t = 0 naming the guide's friction, that the cart is held from the start with nothing
    else free and that the forward method is expected (on the base: "a joint sticks in a model with guides or rigid
    links", pointing at no method)."""
    with pytest.raises(SceneError) as raised:
        latdyn.run(latdyn.load_scene(_with(HELD_CART, sensitivity_method="adjoint")))
    message = str(raised.value)
    assert raised.value.key == "bodies.cart.guide.friction"
    assert "at t = 0 the joint is held by friction from the start" in message and "nothing else free" in message
    assert "expected solve.sensitivity_method: forward" in message and "sticks in a model" not in message


def test_the_release_of_a_cart_held_from_the_start_is_refused_saying_so(tmp_path):
    """Pushed by P t along x the cart breaks away at t = 0.87: the forward method refuses the release (its candidate is
    not prepared where nothing was free), exit 2 naming the guide's friction, the time and the release, without a
    traceback (on the base: "several joints stick or slip, or a latch, a stop or a cable's change comes")."""
    pushed = (HELD_CART.replace("m: 1.0}", "m: 1.0, P: 3.0}")
              .replace("solve:", 'loads:\n  - {at: cart, force: ["P*t", 0, 0]}\nsolve:')
              .replace("t_end: 0.1, sensitivities: [Fc, m]", "t_end: 0.9, sensitivities: [Fc, m, P]"))
    assert pushed.count("P*t") == 1 and "t_end: 0.9" in pushed
    completed, _ = latdyn_run(tmp_path, pushed, quiet=True)
    assert completed.returncode == 2, completed.stderr
    assert "bodies.cart.guide.friction: at t = 0.87 the joint is released after steps on which nothing was free" \
        in completed.stderr
    assert "several joints" not in completed.stderr and "Traceback" not in completed.stderr


#: the wheel on a skew hinge at a stiff arm's end (tests/test_sensitivities_events.py's WHEEL_3D), driven by a torque law
WHEEL_DRIVEN = """
title: a wheel on a skew hinge at the end of a stiff arm, driven by a torque law of its angle and rate
parameters: {k: 1.0, c: 0.05, J: 1.0, EI: 1.0e4}
sections: {s: {EA: 1.0e6, EIy: "EI", EIz: "EI", GJ: "0.8*EI", rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  wheel: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 1.0, com: [0.05, 0, 0],
          inertia: ["J", "J", "1.2*J"]}
beams:
  arm: {from: base, to: wheel, section: s, elements: 2,
        end: {hinge: {axis: [1, -2, 0], stiffness: 0.5, damping: "c", torque: "LAW"}}}
solve: {analysis: transient, t_end: 0.1, dt: 0.01, sensitivities: [k, c, J]}
output:
  probes:
    angle: {hinge: arm.end, quantity: angle}
"""

#: torque laws whose slope in θ or θ̇ is not finite at the start (θ_0 = θ̇_0 = 0) and what the message names
NOT_FINITE_AT_START = [("k*sqrt(abs(theta))", "its slope in theta nan"), ("k*abs(theta)**0.5", "its slope in theta nan"),
                       ("k*(theta - 0.0)**(1/3)", "its slope in theta not a number (ZeroDivisionError"),
                       ("k*abs(theta_dot)**0.5", "its slope in theta_dot nan")]


@pytest.mark.parametrize(("law", "named"), NOT_FINITE_AT_START)
def test_a_torque_law_with_an_infinite_slope_at_the_start_is_refused_naming_its_key(law, named):
    """SceneError naming beams.arm.end.hinge.torque and the slope (on the base: LinAlgError from the check of what
    holds the coordinates, or Newton's failure at the first step for the rate's)."""
    with pytest.raises(SceneError) as raised:
        latdyn.run(latdyn.load_scene(yaml.safe_load(WHEEL_DRIVEN.replace("LAW", law))))
    assert raised.value.key == "beams.arm.end.hinge.torque"
    assert "at the joint's start (theta = 0, theta_dot = 0, t = 0" in str(raised.value) and named in str(raised.value)


def test_latdyn_run_refuses_an_infinite_slope_at_the_start_with_exit_2(tmp_path):
    """Through ``latdyn run``: exit 2 naming the file and the key, no "internal error" (exit 1 with "internal error:
    LinAlgError: Eigenvalues did not converge" on the base)."""
    completed, _ = latdyn_run(tmp_path, WHEEL_DRIVEN.replace("LAW", "k*sqrt(abs(theta))"), quiet=True)
    assert completed.returncode == 2, completed.stderr
    assert "scene.yaml: beams.arm.end.hinge.torque: expected a law finite, with finite slopes" in completed.stderr
    assert "internal error" not in completed.stderr and "Traceback" not in completed.stderr


def test_a_guide_stiffness_with_an_infinite_slope_at_the_start_is_refused_naming_its_key():
    """A guide's law is a joint's law too: its key bodies.NAME.guide.stiffness."""
    text = (HELD_CART.replace('friction: {coulomb: "Fc", static: "Fs"}', 'stiffness: "1 + sqrt(abs(s))"'))
    assert "sqrt" in text
    with pytest.raises(SceneError) as raised:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert raised.value.key == "bodies.cart.guide.stiffness" and "its slope in s nan" in str(raised.value)
    assert "at the joint's start (s = 0, s_dot = 0, t = 0" in str(raised.value)


def test_the_largest_gap_reads_round_off_of_an_exact_zero_as_round_off():
    """Two runs' summaries whose out-of-plane output is round-off (1e-17, 3e-17) beside a position's derivatives of
    order 1: a gap of 2e-17 of the run's scale, not 0.67 (on the base); a real gap of 1e-6 in the position's
    derivatives, and one of 1e-9 in an output 1e-5 of the run's scale, are read as such."""
    forward = {"x": {"end": {"k": 0.8, "m": -1.2}}, "z": {"end": {"k": 1e-17, "m": -3e-17}}}
    adjoint = {"x": {"end": {"k": 0.8, "m": -1.2}}, "z": {"end": {"k": 3e-17, "m": -1e-17}}}
    assert _largest_gap(adjoint, forward) <= 1e-10
    adjoint["x"]["end"]["m"] = -1.2 * (1 + 1e-6)
    assert _largest_gap(adjoint, forward) == pytest.approx(1e-6, rel=1e-6)
    forward["y"] = {"end": {"k": 1e-5, "m": 0.0}}
    adjoint = {**forward, "y": {"end": {"k": 1e-5 * (1 + 1e-9), "m": 0.0}}}
    assert _largest_gap(adjoint, forward) == pytest.approx(1e-9, rel=1e-6)
