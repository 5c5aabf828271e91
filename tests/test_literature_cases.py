"""Held-out-style literature cases, as a user types them, against published or exact references.

The references and the convergence studies are in benchmarks/literature_cases.py (the continuum rod
solutions by shooting; ``python benchmarks/literature_cases.py``); docs/verification.md, "Literature
cases", gives each case's measured error against its mesh and step. Here the fast versions: each
mesh or step is one the studies show to be converged to well inside the tolerance asserted.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

import latdyn
from cli_runs import latdyn_run, probe_columns, summary_of

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.literature_cases import (  # noqa: E402
    ARCH_LIMIT, BEND_TIP, FOLLOWER_TIP, PINNED_ARCH_BIFURCATION, PINNED_ARCH_LIMIT, TOGGLE_LIMIT, TOGGLE_MINIMUM, bent_cantilever,
    column_frequency_hz, deep_arch, follower_cantilever, loaded_column, torque_free_period, williams_toggle,
)


def run_api(text: str):
    return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def _vector(a) -> str:
    return "[" + ", ".join(f"{x:.17g}" for x in a) + "]"


# ----------------------------------------------------------------------------- arches past limit points
def test_deep_arch_limit_load_by_arc_length_against_the_elastica(tmp_path):
    """DaDeppo & Schmidt's 215° clamped–pinned arch under a crown load, traced by arc length through
    its limit point (the straight segments' polygon errs by O(h²): 20 and 40 segments extrapolated)."""
    completed, out = latdyn_run(tmp_path, deep_arch(40))
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["status"] == "solved" and summary["load_factor_reached"] == 1.0
    first = summary["limit_points"][0]
    assert first["kind"] == "maximum"
    fine = first["load_factor"] * 12.0
    assert abs(fine / ARCH_LIMIT - 1) < 4e-3  # measured +2.8e-3 (40 segments)
    coarse = run_api(deep_arch(20)).summary["limit_points"][0]["load_factor"] * 12.0
    extrapolated = fine + (fine - coarse) / 3
    assert abs(extrapolated / ARCH_LIMIT - 1) < 2e-4  # measured −4e-5
    assert probe_columns(out)["crown_v"].min() < -1.1  # past the limit point (crown deflection 1.137 R there)


def test_a_pinned_arch_bifurcates_before_its_limit_point():
    """A pinned–pinned 120° arch under a crown load leaves its symmetric path sideways (in its plane)
    at P R²/EI = 11.4357, before the symmetric limit point 13.7006 (the elastica, benchmarks/
    literature_cases.py). Arc length stays on the symmetric path (no branch switching) and reports
    the bifurcation between two rows and the limit point; ``analysis: buckling`` (out of the plane
    stiff: with GJ = EIy = EI the arch buckles out of its plane first, at 7.49) finds the bifurcation,
    second order in the segments."""
    path = run_api(deep_arch(20, P=15.0, opening=120.0, pinned_start=True)).summary
    low, high = (15 * x for x in path["bifurcation_points"][0]["between_load_factors"])
    assert low < PINNED_ARCH_BIFURCATION < high and path["bifurcation_points"][0]["negative_eigenvalues"] == [0, 1]
    assert abs(15 * path["limit_points"][0]["load_factor"] / PINNED_ARCH_LIMIT - 1) < 3e-3  # measured +1.7e-3
    stiff = "EIy: 1.0e4, EIz: 1.0, GJ: 1.0e4"
    factors = [15 * run_api(deep_arch(n, P=15.0, opening=120.0, pinned_start=True, analysis="buckling").replace(
        "EIy: 1.0, EIz: 1.0, GJ: 1.0", stiff)).summary["buckling_factor"] for n in (20, 40)]
    assert abs(factors[1] / PINNED_ARCH_BIFURCATION - 1) < 5e-4  # measured −2.6e-4 (−1.0e-3 with 20)
    assert abs((factors[1] + (factors[1] - factors[0]) / 3) / PINNED_ARCH_BIFURCATION - 1) < 5e-5  # measured 1e-6


def test_williams_toggle_snaps_through_its_limit_load_by_arc_length(tmp_path):
    """Williams' toggle (clamped bars, rigid apex) past its limit load 33.870 lb and the minimum
    31.282 lb after it (the elastica by shooting, benchmarks/literature_cases.py), 8 elements a bar."""
    completed, out = latdyn_run(tmp_path, williams_toggle(8))
    assert completed.returncode == 0, completed.stderr
    limits = summary_of(out)["limit_points"]
    assert [p["kind"] for p in limits] == ["maximum", "minimum"]
    assert abs(40 * limits[0]["load_factor"] / TOGGLE_LIMIT - 1) < 1e-4  # measured +3.9e-5 (located)
    assert abs(40 * limits[1]["load_factor"] / TOGGLE_MINIMUM - 1) < 1e-4  # measured +1.7e-5 (located)


def test_load_control_stops_at_the_toggles_limit_point_instead_of_snapping_onto_the_far_branch(tmp_path):
    """Past 33.87 lb the toggle's near branch ends and Newton at the next load converged on the far,
    stiffened branch (0.48 in instead of 0.16): load control said 'solved' with no limit point,
    having jumped a snap-through. A step far from the tangent's prediction has left the path: it is
    halved, and the run stops at the limit point as Lee's frame's does (exit 1)."""
    completed, out = latdyn_run(tmp_path, williams_toggle(8, method="load-control"))
    assert completed.returncode == 1
    assert "another branch of the path: a snap-through" in completed.stderr
    summary = summary_of(out)
    assert summary["status"] == "failed"
    assert abs(40 * summary["load_factor_reached"] / TOGGLE_LIMIT - 1) < 1e-4  # measured 2.6e-5
    assert -probe_columns(out)["v"][-1] < 0.25  # the last row on the near branch (v = 0.232 at the limit)


def test_buckling_of_the_toggle_is_its_limit_point_not_a_load_on_the_far_branch():
    """`analysis: buckling` stepped along the path past the limit point onto the far branch, where
    the tangent is positive definite again: it reported no instability (out of the plane stiff) or
    a lateral buckling at 4137 × 40 lb (EIy = EIz). Now the limit point, and with EIy = EIz the
    sideways buckling of the clamped span 2ℓ before it: π²EI/ℓ² axial, P = 2 N sin α = 32.53 lb."""
    stiff = run_api(williams_toggle(8, analysis="buckling", steps=10)).summary
    assert stiff["instability"] == "buckling" and stiff["buckling_kind"].startswith("limit point")
    assert abs(40 * stiff["buckling_factor"] / TOGGLE_LIMIT - 1) < 1e-4  # measured +4.4e-5
    sideways = run_api(williams_toggle(8, analysis="buckling", steps=10,
                                       out_of_plane="EIy: 9274.057316775, GJ: 9274.0")).summary
    bar, slope = math.hypot(12.943, 0.386), math.atan2(0.386, 12.943)
    euler = 2 * math.pi ** 2 * 9274.057316775 / bar ** 2 * math.sin(slope)  # a lower bound: N grows less than P
    assert sideways["buckling_kind"].startswith("bifurcation")
    assert 0.99 * euler < 40 * sideways["buckling_factor"] < TOGGLE_LIMIT  # measured 32.533 (euler 32.48)


# ----------------------------------------------------------------------------- 3D large deflection
def test_45_degree_bend_tip_against_the_kirchhoff_rod():
    """Bathe & Bolourchi's 45° bend under an out-of-plane tip force, P = 300, 450, 600: 8 and 16
    segments extrapolated (second order) against the 3D rod (benchmarks/literature_cases.py)."""
    coarse, fine = run_api(bent_cantilever(8)), run_api(bent_cantilever(16))
    assert fine.summary["status"] == "solved"
    for row, P in ((6, 300), (9, 450), (12, 600)):
        a = np.array([coarse.probes[c][row] for c in "xyz"])
        b = np.array([fine.probes[c][row] for c in "xyz"])
        assert np.linalg.norm(b - BEND_TIP[P]) < 0.03  # measured 0.018 at P = 600 (16 segments; R = 100)
        assert np.linalg.norm(b + (b - a) / 3 - BEND_TIP[P]) < 1e-3  # measured 2.4e-4


# ----------------------------------------------------------------------------- follower loads
def test_follower_tip_force_normal_to_the_tip_through_the_cli(tmp_path):
    """A cantilever whose tip force turns with the tip (``frame: tip``), P L²/EI = 1 … 6."""
    completed, out = latdyn_run(tmp_path, follower_cantilever(8))
    assert completed.returncode == 0, completed.stderr
    assert summary_of(out)["conservative"] is False
    columns = probe_columns(out)
    for k in range(1, 7):
        assert math.hypot(columns["x"][k] - FOLLOWER_TIP[k][0], columns["y"][k] - FOLLOWER_TIP[k][1]) < 2e-5
        # measured ≤ 5.2e-6 (8 elements; 3.1e-7 with 16)


def test_follower_tip_force_of_the_scene_turned_out_of_every_plane():
    """The same cantilever turned by a rotation out of every coordinate plane (a 3D model): the
    tip seen in the turned axes is the planar one."""
    Q = Rotation.from_rotvec([0.4, -0.7, 0.5]).as_matrix()
    text = f"""\
title: follower tip force, turned
sections:
  s: {{EA: 1.0e5, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: {_vector(Q[:, 0])}}}
beams:
  arm: {{from: base, to: tip, section: s, elements: 8, y_axis: {_vector(Q[:, 1])}}}
loads:
  - {{at: tip, force: {_vector(6.0 * Q[:, 1])}, frame: tip}}
solve: {{analysis: static, steps: 6}}
output:
  probes:
    x: {{point: tip, quantity: position, component: x}}
    y: {{point: tip, quantity: position, component: y}}
    z: {{point: tip, quantity: position, component: z}}
"""
    result = run_api(text)
    local = Q.T @ np.array([result.probes[c] for c in "xyz"])
    for k in range(1, 7):
        assert abs(local[2, k]) < 1e-12
        assert math.hypot(local[0, k] - FOLLOWER_TIP[k][0], local[1, k] - FOLLOWER_TIP[k][1]) < 2e-5


# ----------------------------------------------------------------------------- modes of loaded and spinning structures
def test_frequencies_of_a_pinned_column_fall_with_its_compression():
    """ω₁² = ω₀²(1 − P/P_cr) about the static state, P/P_cr = 0.51 and 0.993, and under tension."""
    for P, tol in ((5.0, 5e-5), (9.8, 3e-3), (-20.0, 5e-5)):
        f = np.asarray(run_api(loaded_column(8, P)).modes)
        exact = column_frequency_hz(1, P)
        nearest = f[np.argmin(np.abs(f - exact))]
        assert abs(nearest / exact - 1) < tol, (P, nearest, exact)  # measured 3.3e-5, 2.3e-3, 1e-5
        assert f.min() == nearest  # the in-plane bending mode is the lowest
        second = f[np.argmin(np.abs(f - column_frequency_hz(2, P)))]
        assert abs(second / column_frequency_hz(2, P) - 1) < 5e-4  # measured 3e-4 (P = 5)


BLADES = """\
title: rotor blades on a lag hinge and a flap hinge with offset
sections:
  blade: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 3.0}
bodies:
  hub: {at: [0, 0, 0], motion: {rotation: {axis: [0, 0, 1], angle: "10*t"}}}
beams:
  lag: {from: {body: hub, offset: [0.5, 0, 0]}, to: [2.5, 0, 0], section: blade, rigid: true, start: {hinge: {axis: [0, 0, 1]}}}
  flap: {from: {body: hub, offset: [-0.5, 0, 0]}, to: [-2.5, 0, 0], section: blade, rigid: true, start: {hinge: {axis: [0, 1, 0]}}}
solve: {analysis: modes, about: steady, count: 2}
"""


def test_lag_and_flap_frequencies_of_hinged_rotor_blades():
    """Hinge offset e = 0.5, blade l = 2, Ω = 10: ω_lag = Ω√(3e/2l), ω_flap = Ω√(1 + 3e/2l)."""
    result = run_api(BLADES)
    exact = 10 * np.sqrt([0.375, 1.375]) / (2 * np.pi)
    assert np.allclose(result.modes, exact, rtol=1e-9, atol=0)  # measured 1e-15 (rigid links: no mesh)
    assert result.summary["steady_state"]["stable"] is True


def test_a_free_symmetric_gyroscope_precesses_at_c_omega_over_a():
    """A free body (A, A, C) = (2, 2, 3) spinning at 4 rad/s about its axis, the axis turned out of
    every coordinate plane: modes about ``{t: 0.37}`` give the precession C ω / A = 6 rad/s."""
    Q = Rotation.from_rotvec([0.3, -0.5, 0.2]).as_matrix()
    inertia = Q @ np.diag([2.0, 2.0, 3.0]) @ Q.T
    text = f"""\
title: free symmetric gyroscope
bodies:
  rotor: {{at: [0, 0, 0], mass: 1.5, inertia: [{', '.join(_vector(r) for r in inertia)}]}}
initial_velocity: {{angular: {_vector(4.0 * Q[:, 2])}}}
solve: {{analysis: modes, about: {{t: 0.37}}, count: 6, t_end: 1.0, dt: 0.001}}
"""
    f = np.asarray(run_api(text).modes)
    assert abs(f.max() / (6.0 / (2 * np.pi)) - 1) < 1e-8  # measured 4e-10
    assert np.sum(f > 1e-6) == 1


# ----------------------------------------------------------------------------- rigid-body motion
TUMBLING = """\
title: torque-free rigid body
sections:
  none: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.0}
bodies:
  box: {at: [0, 0, 0], mass: 1.0, inertia: [1.0, 2.0, 3.0]}
beams:
  pointer: {from: box, to: [0, 1, 0], section: none, rigid: true}
initial_velocity: {angular: [0.3, 0.1, 2.0]}
solve: {t_end: 8.0, dt: DT}
output:
  probes:
    x: {point: pointer.end, quantity: position, component: x}
    y: {point: pointer.end, quantity: position, component: y}
    z: {point: pointer.end, quantity: position, component: z}
    kinetic: {energy: kinetic}
    Lx: {momentum: angular, component: x}
    Ly: {momentum: angular, component: y}
    Lz: {momentum: angular, component: z}
"""


def _crossings(t, f):
    i = np.nonzero(np.sign(f[:-1]) != np.sign(f[1:]))[0]
    return t[i] - f[i] * (t[i + 1] - t[i]) / (f[i + 1] - f[i])


def test_torque_free_body_tumbles_with_the_elliptic_period_at_order_two():
    """Euler's equations of a free body (1, 2, 3): the pointer along body y gives L·x = I₂ ω₂(t), whose
    period is 4K(k)/… (Jacobi); its error falls as dt², and the energy and momentum stay."""
    inertia, omega = np.array([1.0, 2.0, 3.0]), np.array([0.3, 0.1, 2.0])
    L, exact = inertia * omega, torque_free_period(inertia, omega)
    errors = []
    for dt in (0.01, 0.005):
        r = run_api(TUMBLING.replace("DT", str(dt)))
        omega2 = (L[0] * r.probes["x"] + L[1] * r.probes["y"] + L[2] * r.probes["z"]) / inertia[1]
        periods = 2 * np.diff(_crossings(np.asarray(r.t), omega2))
        assert len(periods) >= 4 and np.ptp(periods) < 1e-6 * exact
        errors.append(periods.mean() / exact - 1)
        drift = max(abs(r.probes[k][-1] - L[i]) for i, k in enumerate(("Lx", "Ly", "Lz")))
        assert drift < 2.0 * dt ** 2 * np.linalg.norm(L)  # measured 1.01 dt² |L|, 1.01 dt² |L|
        assert abs(r.probes["kinetic"][-1] / r.probes["kinetic"][0] - 1) < 3e-3 * dt ** 2  # measured 1.7e-3 dt²
    assert 0 < errors[1] < 3e-4  # measured 1.86e-4 (dt = 0.01), 4.6e-5 (0.005)
    assert 3.5 < errors[0] / errors[1] < 4.5  # second order


# ----------------------------------------------------------------------------- modes of a tumbling body: flagged
def _spinning_box(axis: int) -> str:
    omega = [0.0, 0.0, 0.0]
    omega[axis] = 4.0
    return f"""\
title: a free box spinning about a principal axis
bodies:
  box: {{at: [0, 0, 0], mass: 1.5, inertia: [1.0, 2.0, 3.0]}}
initial_velocity: {{angular: {omega}}}
solve: {{analysis: modes, about: {{t: 0.37}}, count: 6, t_end: 1.0, dt: 0.001}}
"""


def test_frozen_modes_of_a_body_spinning_about_its_intermediate_axis_are_flagged(tmp_path):
    """Spinning at ω = 4 about its intermediate axis (I = 1, 2, 3) the box diverges at
    ω√((I₂ − I₁)(I₃ − I₂)/(I₁I₃)) = 2.31 1/s (Euler; the Dzhanibekov effect), yet the modes of its
    equations frozen at T in the inertial frame are all zero: the run is solved (these are the frozen
    modes) and says that they do not judge the motion.  It said nothing before."""
    completed, out = latdyn_run(tmp_path, _spinning_box(1))
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["status"] == "solved"
    assert any("turns in the frame of the modes" in w and "box at 4 rad/s" in w for w in summary["warnings"])
    assert "turns in the frame of the modes" in completed.stderr


def test_modes_of_blades_turning_with_their_hub_are_not_flagged():
    """The hinged blades about {t: 0.3} turn with the hub, whose rate is the frame's: no flag, and the
    modes are those about steady."""
    result = run_api(BLADES.replace("about: steady, count: 2", "about: {t: 0.3}, count: 2, t_end: 1.0, dt: 0.001"))
    assert "warnings" not in result.summary
    assert np.allclose(result.modes, 10 * np.sqrt([0.375, 1.375]) / (2 * np.pi), rtol=1e-9, atol=0)


ROTOR = """\
title: a spinning disc at the tip of a massless cantilever shaft
sections:
  shaft: {EA: 1.0e4, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.0}
  axle: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1, 0, 0]}
  disc: {at: [1.05, 0, 0], com: [-0.05, 0, 0], mass: 2.0, inertia: [0.08, 0.05, 0.05]}
beams:
  shaft: {from: base, to: tip, section: shaft}
  axle: {from: tip, to: disc, section: axle, rigid: true, start: {hinge: {axis: [1, 0, 0], angle: "20*t"}}}
solve: {analysis: modes, about: {t: 0.5}, count: 8, t_end: 1.0, dt: 0.001}
"""


def test_forward_and_backward_whirl_of_a_spinning_disc_on_a_cantilever_shaft():
    """A disc (m = 2, I_d = 0.05, I_p = 0.08) spinning at Ω = 20 on a bearing at the tip of a massless
    cantilever shaft (EI = 1, L = 1): the gyroscopic moment splits each whirl into a forward and a
    backward one, det [[k₁₁ − mω², k₁₂], [k₁₂, k₂₂ − I_d ω² ± I_p Ω ω]] = 0 with the shaft's exact
    tip stiffness (12, −6, 4) EI/L^(3, 2, 1). The disc spins about its axis of symmetry: not flagged."""
    result = run_api(ROTOR)
    assert "warnings" not in result.summary
    f = np.asarray(result.modes)
    exact = []
    for sign in (1, -1):
        polynomial = np.poly1d([-2.0, 0, 12.0]) * np.poly1d([-0.05, sign * 0.08 * 20, 4.0]) - 36.0
        exact += [r.real / (2 * np.pi) for r in polynomial.roots if abs(r.imag) < 1e-9 and r.real > 0]
    for value in exact:  # 0.0837, 0.2907, 0.5792, 5.465 Hz (the shaft's axial and torsional modes besides)
        assert np.min(np.abs(f - value)) < 1e-7 * value  # measured < 1e-9


# ----------------------------------------------------------------------------- latches
LATCHING_PANEL = """\
title: a panel deploying from a free-floating bus latches
sections:
  panel: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.5}
bodies:
  bus: {at: [0, 0, 0], mass: 20.0, inertia: [[4.0, 0.3, 0.1], [0.3, 5.0, -0.2], [0.1, -0.2, 6.0]]}
  tip: {at: [1.5, 0.2, 0.1], mass: 1.0, inertia: [0.1, 0.2, 0.2]}
beams:
  arm: {from: {body: bus, offset: [0.5, 0.2, 0.1]}, to: tip, section: panel, rigid: true,
        start: {hinge: {axis: [0, 0.6, 0.8], stiffness: 2.0, rest_angle: 1.5, lock_at: 1.0}}}
initial_velocity: {linear: [0.3, -0.2, 0.1]}
solve: {t_end: 1.5, dt: 0.002}
output:
  probes:
    angle: {hinge: arm.start, quantity: angle}
    kinetic: {energy: kinetic}
    px: {momentum: linear, component: x}
    py: {momentum: linear, component: y}
    pz: {momentum: linear, component: z}
    Lx: {momentum: angular, component: x}
    Ly: {momentum: angular, component: y}
    Lz: {momentum: angular, component: z}
"""


def test_a_panel_latching_on_a_free_floating_bus_keeps_the_momentum_and_loses_what_the_spring_gave(tmp_path):
    """A preloaded hinge spring (k = 2, rest 1.5 rad) swings a panel out from a drifting bus (3D: a
    skew axis, a full inertia tensor) until it latches at 1 rad. Internal forces and the latch's
    plastic impulse keep the linear and angular momentum; the rate about the hinge is all the relative
    motion, so the latched assembly moves on as one body with the drift it started with: the kinetic
    energy after is ½ M v₀² (M = 21.5), and the latch takes the spring's ½k(1.5² − 0.5²) = 2."""
    completed, out = latdyn_run(tmp_path, LATCHING_PANEL)
    assert completed.returncode == 0, completed.stderr
    summary, c = summary_of(out), probe_columns(out)
    assert [e["kind"] for e in summary["events"]] == ["latch"]
    t_latch = summary["events"][0]["t"]
    assert abs(t_latch - 0.8105) < 2e-4  # 0.810502, 0.810500, 0.810499 at dt = 0.004, 0.002, 0.001
    before, after = c["t"] < t_latch - 1e-9, c["t"] > t_latch + 1e-9
    drift = 0.5 * 21.5 * (0.3 ** 2 + 0.2 ** 2 + 0.1 ** 2)
    assert abs(c["kinetic"][after][0] / drift - 1) < 2e-6  # measured 4.1e-7
    assert np.ptp(c["kinetic"][after]) < 1e-12 * drift
    # the last row before the latch (a step before it: the landing ends on the latch in one step, latdyn.timeloop.landing;
    # at 0.81 s, 1.04e-3 rad short of 1) holds the spring's ½k(1.5² − (1.5 − θ)²) given so far: measured −6.3e-7
    theta = c["angle"][before][-1]
    assert abs(c["kinetic"][before][-1] - drift - (1.5 ** 2 - (1.5 - theta) ** 2)) < 1e-5
    p = np.array([c[k] for k in ("px", "py", "pz")])
    L = np.array([c[k] for k in ("Lx", "Ly", "Lz")])
    assert np.allclose(p[:, 0], [6.45, -4.3, 2.15], rtol=1e-12)
    assert np.abs(p - p[:, :1]).max() < 1e-6 * np.linalg.norm(p[:, 0])  # measured 3.8e-7 (O(dt²) before the latch)
    assert np.abs(L - L[:, :1]).max() < 3e-5  # measured 1.25e-5 (|L| = 0.517; O(dt²) through the latch)
    assert np.allclose(c["angle"][after], 1.0, atol=1e-9)


# ----------------------------------------------------------------------------- friction
SLIDING_BLOCK = """\
title: a block sliding down an oblique guide to rest under Coulomb friction
gravity: [0, 0, -9.81]
bodies:
  block: {at: [0, 0, 0], mass: 2.0, guide: {axis: [1, 1, -1], friction: {coulomb: 20.0}}}
initial_velocity: {linear: [1.7320508075688772, 1.7320508075688772, -1.7320508075688772]}
solve: {t_end: 1.0, dt: 0.002}
output:
  probes:
    s: {guide: block, quantity: position}
    v: {guide: block, quantity: rate}
    f: {guide: block, quantity: force}
"""


def test_a_block_slides_down_an_incline_to_rest_and_sticks():
    """m = 2 at 3 m/s down a guide along (1, 1, −1), F_c = 20 against the weight's pull m g/√3 = 11.33:
    it stops after v₀²/(2a), a = F_c/m − g/√3, at t = v₀/a, and stays, friction holding the pull."""
    result = run_api(SLIDING_BLOCK)
    c = {"t": np.asarray(result.t), **{k: np.asarray(v) for k, v in result.probes.items()}}
    a = 10.0 - 9.81 / math.sqrt(3)
    assert abs(c["s"][-1] - 9.0 / (2 * a)) < 1e-8  # measured 9.7e-10 (dt = 0.004 … 0.001 alike)
    stopped = c["t"][np.argmax(c["v"] == 0.0)]
    assert abs(stopped - 3.0 / a) < 0.002  # measured −1.0e-4: the stick lands within a step
    held = c["t"] > stopped
    assert np.all(c["v"][held] == 0.0) and np.allclose(c["f"][held], -2 * 9.81 / math.sqrt(3), rtol=1e-12)


def test_a_follower_load_on_the_toggle_diverges_at_its_limit_point():
    """The apex load turning with the apex (``frame: apex``; on the symmetric path the apex does not
    turn, so the path is the dead load's): the follower search stepped past the fold onto the far
    branch and said `instability: none` up to λ = 1000. Its steps now stop short of the secant's zero
    of the divergence measure, and a step onto another branch is no equilibrium: the limit point."""
    text = williams_toggle(8, analysis="buckling", steps=10).replace(
        "force: [0, -40.0, 0]}", "force: [0, -40.0, 0], frame: apex}")
    summary = run_api(text).summary
    assert summary["conservative"] is False and summary["instability"] == "divergence"
    assert abs(40 * summary["divergence_factor"] / TOGGLE_LIMIT - 1) < 1e-4  # measured +4.4e-5


# ----------------------------------------------------------------------------- compliant stops
def test_hunt_crossley_rebound_and_penetration_in_closed_form():
    """A slider (m = 1) at 2 m/s along an oblique guide onto a stop with F = kδⁿ(1 + λδ̇), n = 1.5,
    k = 1e4, λ = c/k = 0.2: m u/(1 + λu) du = −kδⁿ dδ integrates over the contact to
    λv_in − ln(1 + λv_in) = −λv_out − ln(1 − λv_out) (Marhefka & Orin 1999) and to the deepest
    penetration δ_max^(n+1) = (n+1)(m/k)(v_in/λ − ln(1 + λv_in)/λ²)."""
    from scipy.optimize import brentq

    lam, v_in, k, n = 0.2, 2.0, 1.0e4, 1.5
    loss = lam * v_in - math.log(1 + lam * v_in)
    v_out = brentq(lambda v: -lam * v - math.log(1 - lam * v) - loss, 1e-9, 1 / lam - 1e-12)
    deepest = ((n + 1) / k * (v_in / lam - math.log(1 + lam * v_in) / lam ** 2)) ** (1 / (n + 1))
    text = f"""\
title: a slider onto a Hunt-Crossley stop
bodies:
  slider: {{at: [0, 0, 0], mass: 1.0, guide: {{axis: [2, -1, 2], limits: [-1.0, 0.1], contact: {{stiffness: {k}, exponent: {n}, damping: {k * lam}}}}}}}
initial_velocity: {{linear: {_vector(v_in * np.array([2, -1, 2]) / 3)}}}
solve: {{t_end: 0.3, dt: 1.0e-4}}
output:
  probes:
    s: {{guide: slider, quantity: position}}
    v: {{guide: slider, quantity: rate}}
"""
    r = run_api(text)
    assert abs(r.probes["v"][-1] / -v_out - 1) < 5e-6  # measured 1.4e-6 (5.6e-6, 3.5e-7 at dt = 2e-4, 5e-5)
    assert abs((max(r.probes["s"]) - 0.1) / deepest - 1) < 1e-4  # v_out 1.5771, δ_max 0.043605


# ----------------------------------------------------------------------------- invariants of a free 3D assembly
FREE_CHAIN = """\
title: a free chain of bodies on skew hinges and flexible beams
sections:
  s: {EA: 1.0e5, EIy: 50.0, EIz: 80.0, GJ: 40.0, rhoA: 0.3, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
  r: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.2}
bodies:
  a: {at: [0, 0, 0], mass: 2.0, inertia: [[0.3, 0.05, 0], [0.05, 0.2, 0.01], [0, 0.01, 0.25]]}
  b: {at: [1.0, 0.3, -0.2], mass: 1.0, com: [0.05, 0, 0.02], inertia: [0.1, 0.12, 0.08]}
  c: {at: [1.4, 1.1, 0.5], mass: 0.5, inertia: [0.02, 0.03, 0.04]}
beams:
  ab: {from: a, to: b, section: s, elements: 3, end: {hinge: {axis: [0.2, 1, 0.4], stiffness: 3.0}}}
  bc: {from: b, to: c, section: r, rigid: true, start: {hinge: {axis: [1, -0.3, 0.6], stiffness: 1.0, rest_angle: 0.4}}}
initial_velocity: {linear: [0.2, -0.1, 0.3], angular: [0.5, -1.0, 2.0], about: [0.5, 0.5, 0]}
solve: {t_end: 2.0, dt: DT}
output:
  probes:
    E: {energy: total}
    px: {momentum: linear, component: x}
    py: {momentum: linear, component: y}
    pz: {momentum: linear, component: z}
    Lx: {momentum: angular, component: x}
    Ly: {momentum: angular, component: y}
    Lz: {momentum: angular, component: z}
"""


def test_a_free_chain_of_bodies_hinges_and_beams_keeps_energy_and_momentum_to_order_two():
    """No external force: the total energy and the linear and angular momentum stay, to the
    integrator's order (measured at dt = 0.002, 0.001, 0.0005: energy 1.9e-5, 4.5e-6, 1.1e-6
    relative; p 1.6e-5, 3.8e-6, 9.7e-7; L 4.1e-5, 1.1e-5, 2.7e-6 with |L| = 5.13)."""
    drifts = []
    for dt in (0.002, 0.001):
        P = {k: np.asarray(v) for k, v in run_api(FREE_CHAIN.replace("DT", str(dt))).probes.items()}
        p = np.array([P[k] for k in ("px", "py", "pz")])
        L = np.array([P[k] for k in ("Lx", "Ly", "Lz")])
        drifts.append((np.abs(P["E"] / P["E"][0] - 1).max(), np.abs(p - p[:, :1]).max(), np.abs(L - L[:, :1]).max()))
    assert drifts[0][0] < 4e-5 and drifts[0][1] < 3e-5 and drifts[0][2] < 8e-5
    for coarse, fine in zip(*drifts):
        assert 3.0 < coarse / fine < 5.0  # second order


def test_modes_about_a_static_state_past_the_euler_load_say_it_is_unstable():
    """The perfect pinned column at P = 12 > π²: load control stays on the straight (unstable) branch;
    its modes hold the divergent root √(π⁴(P/π² − 1)) = 4.585 1/s (damping ratio −1), but the run said
    nothing. Now a warning names the growth rate, as about: steady does."""
    summary = run_api(loaded_column(8, 12.0)).summary
    warning = [w for w in summary["warnings"] if w.startswith("modes about static: the static state is unstable")]
    growth = math.pi ** 2 * math.sqrt(12.0 / math.pi ** 2 - 1)
    assert len(warning) == 1 and f"the lowest grows at {growth:.4g} 1/s by divergence (a real root)" in warning[0]
    assert "past a bifurcation" in warning[0] and "flutter" not in warning[0]
    assert summary["damping_ratios"][0] == -1.0
    assert "warnings" not in run_api(loaded_column(8, 5.0)).summary  # below the Euler load: stable, no word


# ----------------------------------------------------------------------------- cables
DROPPED_ON_A_ROPE = """\
title: a mass dropped on a slack rope
gravity: [0, 0, -9.81]
bodies:
  anchor: {at: [0, 0, 0], fixed: true}
  mass: {at: [0, 0, -1], mass: 2.0, inertia: [0.01, 0.01, 0.01]}
cables:
  rope: {from: anchor, to: mass, EA: 400.0, rest_length: 2.0}
solve: {t_end: 1.2, dt: 0.001}
output:
  probes:
    N: {cable: rope, quantity: tension}
"""


def test_a_mass_dropped_on_a_slack_rope_goes_taut_and_slack_at_the_closed_form_times(tmp_path):
    """Free fall of 1 m onto a rope of k = EA/L₀ = 200: taut at √(2/g), then half a swing of
    ω = √(k/m) about the static stretch mg/k with amplitude A = √((mg/k)² + 2g/ω²), slack again
    (π + 2 asin(mg/kA))/ω later; the largest tension k (mg/k + A)."""
    completed, out = latdyn_run(tmp_path, DROPPED_ON_A_ROPE)
    assert completed.returncode == 0, completed.stderr
    m, g, k = 2.0, 9.81, 200.0
    omega, static = math.sqrt(k / m), m * g / k
    amplitude = math.sqrt(static ** 2 + 2 * g / omega ** 2)
    taut = math.sqrt(2 / g)
    slack = taut + (math.pi + 2 * math.asin(static / amplitude)) / omega
    events = summary_of(out)["cable_events"]
    assert [e["state"] for e in events[:2]] == ["taut", "slack"]
    assert abs(events[0]["t"] - taut) < 1e-9  # measured 2e-15 (free fall: exact)
    assert abs(events[1]["t"] - slack) < 2e-5  # measured 3.2e-6 (1.3e-5, 7.9e-7 at dt = 0.002, 0.0005)
    assert abs(probe_columns(out)["N"].max() / (k * (static + amplitude)) - 1) < 2e-5  # measured 8e-6 (rows)


SLACK_TIE = """\
title: a guided body on a spring pulled until a slack tie goes taut
bodies:
  anchor: {at: [0, 0, 0], fixed: true}
  slider: {at: [1, 0, 0], mass: 1.0, guide: {axis: [1, 0, 0], stiffness: 100.0}}
cables:
  tie: {from: anchor, to: slider, EA: 1.0e5, rest_length: 1.05}
loads:
  - {at: slider, force: [10.0, 0, 0]}
solve: {analysis: static, steps: 10}
output:
  probes:
    s: {guide: slider, quantity: position}
    N: {cable: tie, quantity: tension}
"""


def test_a_tie_going_taut_under_load_control_is_a_kink_of_the_path_not_a_snap_through():
    """The tie goes taut at λ = 0.5 exactly (s = 0.05): from there the tangent (slack) predicts a move
    the stiff path does not make at any step length. That is no jump onto another branch (the path
    is continuous, the step stiffer than the tangent said): solved, at the spring-and-tie equilibrium
    100 s + (EA/L₀)(s − 0.05) = 10."""
    result = run_api(SLACK_TIE)
    assert result.summary["status"] == "solved" and result.summary["rejected_steps"] == 0
    k = 1.0e5 / 1.05
    s = (10.0 + k * 0.05) / (100.0 + k)
    assert abs(result.probes["s"][-1] - s) < 1e-12 and abs(result.probes["N"][-1] - k * (s - 0.05)) < 1e-7


ASYMMETRIC_SHAFT = """\
title: a mass on an asymmetric shaft spinning about its axis
sections:
  shaft: {EA: 1.0e6, EIy: 1.0, EIz: 2.0, GJ: 1.0, rhoA: 0.0}
bodies:
  hub: {at: [0, 0, 0], motion: {rotation: {axis: [1, 0, 0], angle: "OMEGA*t"}}}
  mass: {at: [1, 0, 0], mass: 1.0, inertia: [1.0e-6, 1.0e-6, 1.0e-6]}
beams:
  shaft: {from: hub, to: mass, section: shaft}
solve: {analysis: modes, about: steady, count: 4}
"""


def test_a_mass_on_an_asymmetric_spinning_shaft_is_unstable_between_its_critical_speeds():
    """A tip mass m = 1 on a massless cantilever shaft with tip stiffnesses 3EI/L³ = 3 and 6, spinning
    about its axis: in the turning frame s⁴ + (ω₁² + ω₂² + 2Ω²)s² + (ω₁² − Ω²)(ω₂² − Ω²) = 0, stable
    below √3 (Ω = 1: 1 and √10 rad/s) and divergent between √3 and √6 (Ω = 2: s = 0.34182 1/s)."""
    def roots(omega):
        return np.roots([1.0, 9.0 + 2 * omega ** 2, (3.0 - omega ** 2) * (6.0 - omega ** 2)])

    slow = run_api(ASYMMETRIC_SHAFT.replace("OMEGA", "1.0"))
    assert slow.summary["steady_state"]["stable"] is True
    exact = np.sort(np.sqrt(-roots(1.0))) / (2 * np.pi)
    assert np.allclose(slow.modes[:2], exact, rtol=1e-5)  # measured 1.1e-6 (the mass's 1e-6 inertia, EA)
    fast = run_api(ASYMMETRIC_SHAFT.replace("OMEGA", "2.0")).summary
    growth = math.sqrt(max(roots(2.0).real))
    assert fast["steady_state"]["stable"] is False
    assert abs(fast["steady_state"]["growth_rate"] / growth - 1) < 1e-5  # measured 1e-6
    assert any("unstable" in w for w in fast["warnings"])
