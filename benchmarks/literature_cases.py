"""Held-out-style literature cases: scenes a user would type, against published or exact references.

    python benchmarks/literature_cases.py            # the convergence studies, benchmarks/results/literature_cases.json
    python benchmarks/literature_cases.py --references   # recompute the continuum references (about a minute)

Each case is a scene built as YAML text and run through ``latdyn.run(latdyn.load_scene(...))``
(tests/test_literature_cases.py runs the fast versions, through the command line as well). The
references of the three large-deflection cases are solved here from the continuum rod equations
by shooting (scipy ``solve_ivp`` DOP853 at rtol 1e-12, ``fsolve``), so that a disagreement is
latdyn's and not that of a figure read off a paper:

- **Deep circular arch** (DaDeppo & Schmidt 1975; Simo & Vu-Quoc 1986: 897 for R = 100,
  EI = 1e6): 215°, clamped at one end, pinned at the other, a vertical dead load at the crown,
  followed by arc length past its limit point. The extensible elastica (EA = 1e6 EI/R²) gives the
  limit load P R²/EI = 8.97295 (the crown's deflection 1.1373 R there); the 9.04–9.10 often quoted
  from DaDeppo & Schmidt is above the converged rod solution (Simo & Vu-Quoc's 897 is below it).
- **45° bend** (Bathe & Bolourchi 1979; Simo & Vu-Quoc 1986): R = 100, a unit square section,
  E = 1e7, GJ = 7.05e5, clamped, a tip force P along z out of the bend's plane; the tip's position
  at P = 300, 450, 600 from the 3D extensible, shear-rigid Kirchhoff rod (Simo & Vu-Quoc's
  8-element figures, 47.23, 15.79, 53.37 at P = 600, lie within 0.4 of it).
- **Cantilever under a follower tip force normal to its tip** (Argyris & Symeonidis 1981's
  non-conservative tip load): EI = 1, L = 1, EA = 1e5, the tip's position for P L²/EI = 1 … 6.

Closed forms: a pinned–pinned column under an end load P, ω_n² = (nπ/L)⁴ EI/ρA (1 − P/P_n),
P_n = n²π²EI/L² (modes ``about: static``); the lag and flap hinges of a rotor blade with hinge
offset e (a uniform rigid blade of length l on a hub turning at Ω): ω_lag = Ω √(3e/2l),
ω_flap = Ω √(1 + 3e/2l) (``about: steady``); a free symmetric gyroscope (A, A, C) spinning at ω
about its axis precesses at C ω / A (``about: {t: T}``); the torque-free asymmetric body's
angular velocity is periodic with T = 4 K(k) / √((I₃ − I₂)(M² − 2E I₁)/(I₁I₂I₃)),
k² = (I₂ − I₁)(2E I₃ − M²)/((I₃ − I₂)(M² − 2E I₁)) (Landau & Lifshitz §37; M² > 2E I₂).
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import latdyn  # noqa: E402

# ----------------------------------------------------------------------------- references
#: P R²/EI at the limit point of the 215° arch, EA R²/EI = 1e6 (:func:`arch_limit_reference`).
ARCH_LIMIT = 8.972949
#: The pinned–pinned 120° arch (R = 1, EI = 1, EA = 1e6) under a crown load: P R²/EI at its
#: asymmetric bifurcation and at the symmetric path's limit point (:func:`pinned_arch_reference`).
PINNED_ARCH_BIFURCATION, PINNED_ARCH_LIMIT = 11.435735, 13.700559
#: The tip of the 45° bend (x, y, z) at P = 300, 450, 600 (:func:`bend_reference`).
BEND_TIP = {300: (58.541631, 22.115744, 40.472315),
            450: (51.976228, 18.372607, 48.698165),
            600: (46.898463, 15.560874, 53.601773)}
#: Williams' toggle (clamped bars, rigid apex): the limit load [lb] and the apex deflection [in]
#: there, the minimum load after it and its deflection (:func:`toggle_reference`).
TOGGLE_LIMIT, TOGGLE_LIMIT_V = 33.870385, 0.232157
TOGGLE_MINIMUM, TOGGLE_MINIMUM_V = 31.281774, 0.391594
#: The tip (x, y) of the cantilever under a normal follower force P L²/EI = 1 … 6 (:func:`follower_reference`).
FOLLOWER_TIP = {1: (0.93564420, 0.32064138), 2: (0.76735814, 0.57383522), 3: (0.55165976, 0.72667594),
                4: (0.34274195, 0.78615463), 5: (0.17227584, 0.78067307), 6: (0.04950140, 0.74025520)}


def _planar_rod(EI, EA, curvature0=0.0):
    """Right-hand side of the planar extensible elastica (x, y, θ, M)' with the section force F (global,
    the part s+ on the part s−), shear-rigid: M = EI (θ' − κ₀), r' = (1 + F·t/EA) t, M' = −r' × F."""
    def rhs(s, y, F):
        th, M = y[2], y[3]
        t = np.array([math.cos(th), math.sin(th)])
        rp = (1.0 + F @ t / EA) * t
        return [rp[0], rp[1], curvature0 + M / EI, -(rp[0] * F[1] - rp[1] * F[0])]
    return rhs


def arch_limit_reference(R=1.0, EI=1.0, EA=1e6, opening=215.0) -> tuple[float, float]:
    """(P R²/EI, crown deflection / R) at the limit point of the clamped–pinned circular arch under
    a dead crown load, by shooting from the clamped end (section force, moment) with the crown's
    deflection prescribed, maximising P over it."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import fsolve, minimize_scalar

    half = math.radians(opening / 2)
    L = 2 * half * R
    rhs = _planar_rod(EI, EA, -1.0 / R)
    kw = dict(rtol=1e-12, atol=1e-13, method="DOP853")

    def shoot(u, v):
        Fx, Fy, M0, P = u
        F0 = np.array([Fx, Fy])
        a = solve_ivp(rhs, (0, L / 2), [R * math.sin(-half), R * math.cos(-half), half, M0], args=(F0,), **kw)
        ya = a.y[:, -1]
        yb = solve_ivp(rhs, (L / 2, L), ya, args=(F0 + np.array([0.0, P]),), **kw).y[:, -1]
        return [yb[0] - R * math.sin(half), yb[1] - R * math.cos(half), yb[3], ya[1] - (R - v)]

    u, best = np.zeros(4), (-1.0, 0.0, None)
    for v in np.linspace(0.01, 1.2, 120):
        u = fsolve(shoot, u, args=(v,), xtol=1e-13)
        if u[3] > best[0]:
            best = (u[3], v, u.copy())
    guess = best[2]
    r = minimize_scalar(lambda v: -fsolve(shoot, guess, args=(v,), xtol=1e-13)[3],
                        bracket=(best[1] - 0.01, best[1], best[1] + 0.01), tol=1e-10)
    return -r.fun * R ** 2 / EI, r.x / R


def pinned_arch_reference(R=1.0, EI=1.0, EA=1e6, opening=120.0) -> tuple[float, float]:
    """(bifurcation, limit) P R²/EI of a pinned–pinned circular arch under a dead crown load: the
    symmetric path by shooting from the left pin (section force, end angle; M = 0 at both ends) with
    the crown's deflection prescribed; the bifurcation where the Jacobian of the end conditions in
    the shooting unknowns is singular while P still rises, the limit point where P is largest."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq, fsolve, minimize_scalar

    half = math.radians(opening / 2)
    L = 2 * half * R
    rhs = _planar_rod(EI, EA, -1.0 / R)
    kw = dict(rtol=1e-12, atol=1e-13, method="DOP853")

    def ends(u):
        F0 = np.array(u[:2])
        ya = solve_ivp(rhs, (0, L / 2), [R * math.sin(-half), R * math.cos(-half), u[2], 0.0], args=(F0,), **kw).y[:, -1]
        return ya, solve_ivp(rhs, (L / 2, L), ya, args=(F0 + np.array([0.0, u[3]]),), **kw).y[:, -1]

    def conditions(u):
        yb = ends(u)[1]
        return np.array([yb[0] - R * math.sin(half), yb[1] - R * math.cos(half), yb[3]])

    def shoot(u, v):
        return list(conditions(u)) + [ends(u)[0][1] - (R - v)]

    def det(u, h=1e-6):
        columns = []
        for j in range(3):
            e = np.zeros(4)
            e[j] = h
            columns.append((conditions(u + e) - conditions(u - e)) / (2 * h))
        return np.linalg.det(np.array(columns).T)

    u, rows = np.array([0.0, 0.0, half, 0.0]), []
    for v in np.linspace(0.005, 0.6, 120):
        u = fsolve(shoot, u, args=(v,), xtol=1e-13)
        rows.append((v, u.copy(), det(u)))
    first = next(i for i in range(1, len(rows)) if np.sign(rows[i][2]) != np.sign(rows[i - 1][2]))
    start = rows[first - 1][1]
    vb = brentq(lambda v: det(fsolve(shoot, start, args=(v,), xtol=1e-13)), rows[first - 1][0], rows[first][0], xtol=1e-10)
    top = max(range(len(rows)), key=lambda i: rows[i][1][3])
    guess = rows[top][1]
    limit = minimize_scalar(lambda v: -fsolve(shoot, guess, args=(v,), xtol=1e-13)[3],
                            bracket=(rows[top - 1][0], rows[top][0], rows[top + 1][0]), tol=1e-10)
    return float(fsolve(shoot, start, args=(vb,), xtol=1e-13)[3]), float(-limit.fun)


def toggle_reference() -> tuple[tuple[float, float], tuple[float, float]]:
    """((limit load, deflection), (minimum load, deflection)) of Williams' toggle on its symmetric path:
    two bars (half-span a = 12.943 in, rise h = 0.386 in, E = 10.3e6 psi, b × d = 0.753 × 0.243 in)
    clamped at the supports and rigidly joined at the apex, a dead load P down at the apex; shooting
    from the left support (section force, moment, P) with the apex deflection v prescribed."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import fsolve, minimize_scalar

    a, h, E, b, d = 12.943, 0.386, 10.3e6, 0.753, 0.243
    EA, EI = E * b * d, E * b * d ** 3 / 12
    bar, slope = math.hypot(a, h), math.atan2(h, a)
    rhs = _planar_rod(EI, EA)
    kw = dict(rtol=1e-12, atol=1e-13, method="DOP853")

    def shoot(u, v):
        F0 = np.array(u[:2])
        ya = solve_ivp(rhs, (0, bar), [-a, 0, slope, u[2]], args=(F0,), **kw).y[:, -1]
        start = ya.copy()
        start[2] -= 2 * slope  # the rigid apex turns the tangent by the bars' angle
        yb = solve_ivp(rhs, (bar, 2 * bar), start, args=(F0 + np.array([0.0, u[3]]),), **kw).y[:, -1]
        return [yb[0] - a, yb[1], yb[2] + slope, ya[1] - (h - v)]

    u = np.zeros(4)
    for v in np.linspace(0.005, 0.24, 48):
        u = fsolve(shoot, u, args=(v,), xtol=1e-13)
    top = minimize_scalar(lambda v: -fsolve(shoot, u, args=(v,), xtol=1e-13)[3], bracket=(0.2, 0.24, 0.29), tol=1e-10)
    for v in np.linspace(0.24, 0.4, 33):
        u = fsolve(shoot, u, args=(v,), xtol=1e-13)
    low = minimize_scalar(lambda v: fsolve(shoot, u, args=(v,), xtol=1e-13)[3], bracket=(0.36, 0.4, 0.44), tol=1e-10)
    return (-top.fun, top.x), (low.fun, low.x)


def bend_reference(loads=(300.0, 450.0, 600.0)) -> dict:
    """The tip of the 45° bend under a tip force P e_z: the 3D Kirchhoff rod (extensible,
    shear-rigid) by shooting on the root moment, the section force P e_z all along."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import fsolve

    R, EA, EI, GJ = 100.0, 1e7, 1e7 / 12, 705000.0
    L, stiffness = R * math.pi / 4, np.array([GJ, EI, EI])

    def hat(w):
        return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])

    def rhs(s, y, F):
        Q, M = y[3:12].reshape(3, 3), y[12:15]
        kappa = np.array([0, 0, 1 / R]) + (Q.T @ M) / stiffness
        rp = (1 + F @ Q[:, 0] / EA) * Q[:, 0]
        return np.concatenate([rp, (Q @ hat(kappa)).ravel(), -np.cross(rp, F)])

    def tip(M0, P):
        y0 = np.concatenate([[0, 0, 0], np.eye(3).ravel(), M0])
        return solve_ivp(rhs, (0, L), y0, args=(np.array([0, 0, P]),), rtol=1e-12, atol=1e-12,
                         method="DOP853").y[:, -1]

    M0, out = np.zeros(3), {}
    for P in np.linspace(25, max(loads), int(max(loads) / 25)):
        M0 = fsolve(lambda m: tip(m, P)[12:15], M0, xtol=1e-13)
        if any(abs(P - p) < 1e-9 for p in loads):
            out[int(round(P))] = tuple(float(c) for c in tip(M0, P)[:3])
    return out


def follower_reference(loads=(1, 2, 3, 4, 5, 6), EI=1.0, EA=1e5, L=1.0) -> dict:
    """The tip (x, y) of a cantilever along x under a tip force P that stays normal to the tip:
    shooting on (root moment, tip angle), loads stepped from 0.25 in 0.25."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import fsolve

    rhs = _planar_rod(EI, EA)
    kw = dict(rtol=1e-12, atol=1e-13, method="DOP853")

    def end(u, P):
        F = P * np.array([-math.sin(u[1]), math.cos(u[1])])
        return solve_ivp(rhs, (0, L), [0, 0, 0, u[0]], args=(F,), **kw).y[:, -1]

    u, out = np.zeros(2), {}
    for P in np.arange(0.25, max(loads) + 1e-9, 0.25):
        u = fsolve(lambda w: [end(w, P)[3], end(w, P)[2] - w[1]], u, xtol=1e-13)
        if any(abs(P - p) < 1e-9 for p in loads):
            y = end(u, P)
            out[int(round(P))] = (float(y[0]), float(y[1]))
    return out


def column_frequency_hz(n: int, P: float, EI=1.0, rhoA=1.0, L=1.0) -> float:
    """The n-th bending frequency of a pinned–pinned column under the end load P (compression > 0)."""
    k = n * math.pi / L
    return k * k * math.sqrt(EI / rhoA * (1.0 - P / (EI * k * k))) / (2 * math.pi)


def torque_free_period(inertia, omega0) -> float:
    """The period of the body-frame angular velocity of a torque-free body (I₁ < I₂ < I₃, M² > 2E I₂)."""
    from scipy.special import ellipk

    I1, I2, I3 = inertia
    w = np.asarray(omega0, float)
    E2, M2 = float(np.dot(inertia, w * w)), float(np.dot(np.multiply(inertia, w), np.multiply(inertia, w)))
    assert I1 < I2 < I3 and M2 > E2 * I2
    k2 = (I2 - I1) * (E2 * I3 - M2) / ((I3 - I2) * (M2 - E2 * I1))
    return 4 * ellipk(k2) / math.sqrt((I3 - I2) * (M2 - E2 * I1) / (I1 * I2 * I3))


# ----------------------------------------------------------------------------- scenes (YAML text)
def deep_arch(segments: int, P: float = 12.0, steps: int = 20, EA: float = 1e6, opening: float = 215.0,
              pinned_start: bool = False, analysis: str = "static, method: arc-length") -> str:
    """The 215° arch (R = 1, EI = 1) as straight beams between massless joint bodies on the circle,
    one element each; clamped at n0 (pinned with ``pinned_start``), pinned (hinge about z) at the
    last; arc length to P (``analysis``: what follows ``analysis:`` in ``solve``)."""
    half = math.radians(opening / 2)
    lines = [f"title: circular arch, {opening:g} degrees, crown load", "sections:",
             f"  s: {{EA: {EA}, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}", "bodies:"]
    for i in range(segments + 1):
        a = -half + 2 * half * i / segments
        fixed = ", fixed: true" if i in (0, segments) else ""
        lines.append(f"  n{i}: {{at: [{math.sin(a):.17g}, {math.cos(a):.17g}, 0]{fixed}}}")
    lines.append("beams:")
    for i in range(segments):
        pin = ", end: {hinge: {axis: [0, 0, 1]}}" if i == segments - 1 else ""
        if i == 0 and pinned_start:
            pin += ", start: {hinge: {axis: [0, 0, 1]}}"
        lines.append(f"  b{i}: {{from: n{i}, to: n{i + 1}, section: s{pin}}}")
    crown = segments // 2
    lines += ["loads:", f"  - {{at: n{crown}, force: [0, {-P}, 0]}}",
              f"solve: {{analysis: {analysis}, steps: {steps}}}",
              "output:", "  probes:", f"    crown_v: {{point: n{crown}, quantity: displacement, component: y}}"]
    return "\n".join(lines) + "\n"


def bent_cantilever(segments: int, P: float = 600.0, steps: int = 12) -> str:
    """The 45° bend (R = 100 in the x–y plane, centre (0, 100)) as straight beams between massless
    joint bodies, one element each; a tip force P along z, load control in ``steps``."""
    lines = ["title: Bathe-Bolourchi 45-degree bend", "sections:",
             "  sq: {EA: 1.0e7, EIy: 833333.3333333334, EIz: 833333.3333333334, GJ: 705000.0, rhoA: 1.0}",
             "bodies:"]
    for i in range(segments + 1):
        a = math.pi / 4 * i / segments
        fixed = ", fixed: true" if i == 0 else ""
        lines.append(f"  p{i}: {{at: [{100 * math.sin(a):.17g}, {100 * (1 - math.cos(a)):.17g}, 0]{fixed}}}")
    lines.append("beams:")
    lines += [f"  s{i}: {{from: p{i}, to: p{i + 1}, section: sq}}" for i in range(segments)]
    lines += ["loads:", f"  - {{at: p{segments}, force: [0, 0, {P}]}}",
              f"solve: {{analysis: static, steps: {steps}}}", "output:", "  probes:"]
    lines += [f"    {c}: {{point: p{segments}, quantity: position, component: {c}}}" for c in "xyz"]
    return "\n".join(lines) + "\n"


def follower_cantilever(elements: int, P: float = 6.0, steps: int = 6) -> str:
    """A cantilever along x (EI = 1, L = 1) whose tip body carries a force P along its own y axis."""
    return f"""\
title: cantilever under a follower tip force normal to its tip
sections:
  s: {{EA: 1.0e5, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [1, 0, 0]}}
beams:
  arm: {{from: base, to: tip, section: s, elements: {elements}}}
loads:
  - {{at: tip, force: [0, {P}, 0], frame: tip}}
solve: {{analysis: static, steps: {steps}}}
output:
  probes:
    x: {{point: tip, quantity: position, component: x}}
    y: {{point: tip, quantity: position, component: y}}
"""


def loaded_column(elements: int, P: float, EA: float = 1e8) -> str:
    """A pinned–pinned column (EI = 1, ρA = 1, L = 1): a hinge at the base, a hinge to a massless
    roller guided along x at the top, an end load P (compression > 0); modes about the static state."""
    return f"""\
title: pinned-pinned column under an end load
sections:
  s: {{EA: {EA}, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  roller: {{at: [1, 0, 0], guide: {{axis: [1, 0, 0]}}}}
beams:
  col: {{from: base, to: roller, section: s, elements: {elements}, start: {{hinge: {{axis: [0, 0, 1]}}}}, end: {{hinge: {{axis: [0, 0, 1]}}}}}}
loads:
  - {{at: roller, force: [{-P}, 0, 0]}}
solve: {{analysis: modes, about: static, steps: 4, count: 4}}
"""


def williams_toggle(elements: int, analysis: str = "static", method: str = "arc-length", P: float = 40.0,
                    steps: int = 20, out_of_plane: str = "EIy: 1.0e9, GJ: 1.0e9") -> str:
    """Williams' toggle (kip-free units: lb, in), ``elements`` per bar; out of the plane stiff by
    default (the clamped span 2ℓ buckles sideways at 32.5 lb with EIy = EIz, before the limit point)."""
    solve = (f"{{analysis: buckling, steps: {steps}}}" if analysis == "buckling"
             else f"{{analysis: static, method: {method}, steps: {steps}}}")
    return f"""\
title: Williams' toggle
sections:
  bar: {{EA: 1884683.7, EIz: 9274.057316775, {out_of_plane}, rhoA: 1.0}}
bodies:
  left: {{at: [-12.943, 0, 0], fixed: true}}
  right: {{at: [12.943, 0, 0], fixed: true}}
  apex: {{at: [0, 0.386, 0]}}
beams:
  a: {{from: left, to: apex, section: bar, elements: {elements}}}
  b: {{from: apex, to: right, section: bar, elements: {elements}}}
loads:
  - {{at: apex, force: [0, {-P}, 0]}}
solve: {solve}
output:
  probes:
    v: {{point: apex, quantity: displacement, component: y}}
"""


def _run(text: str):
    import yaml

    t0 = time.perf_counter()
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    return result, time.perf_counter() - t0


# ----------------------------------------------------------------------------- convergence studies
def study() -> dict:
    out = {}
    rows = []
    for n in (20, 40, 80):
        r, wall = _run(deep_arch(n))
        lam = r.summary["limit_points"][0]["load_factor"] * 12.0
        rows.append({"segments": n, "limit_PR2_EI": lam, "error": lam / ARCH_LIMIT - 1, "wall_s": wall})
    out["deep_arch"] = rows
    rows = []
    for n in (8, 16, 32):
        r, wall = _run(bent_cantilever(n))
        tip = [float(r.probes[c][-1]) for c in "xyz"]
        rows.append({"segments": n, "tip_600": tip,
                     "error": float(np.linalg.norm(np.subtract(tip, BEND_TIP[600]))), "wall_s": wall})
    out["bend_45"] = rows
    rows = []
    for n in (4, 8, 16):
        r, wall = _run(follower_cantilever(n))
        err = max(math.hypot(r.probes["x"][k] - FOLLOWER_TIP[k][0], r.probes["y"][k] - FOLLOWER_TIP[k][1])
                  for k in range(1, 7))
        rows.append({"elements": n, "max_tip_error": err, "wall_s": wall})
    out["follower_tip_force"] = rows
    rows = []
    for n in (4, 8, 16):
        for P in (5.0, 9.8, -20.0):
            r, wall = _run(loaded_column(n, P))
            f = [float(x) for x in r.modes]
            in_plane = sorted(f, key=lambda x: abs(x - column_frequency_hz(1, P)))[0]
            rows.append({"elements": n, "P": P, "f1_hz": in_plane,
                         "error": in_plane / column_frequency_hz(1, P) - 1, "wall_s": wall})
    out["loaded_column"] = rows
    rows = []
    for n in (4, 8, 16):
        r, wall = _run(williams_toggle(n))
        top, low = (40.0 * p["load_factor"] for p in r.summary["limit_points"][:2])
        rows.append({"elements": n, "limit_lb": top, "limit_error": top / TOGGLE_LIMIT - 1, "minimum_lb": low,
                     "minimum_error": low / TOGGLE_MINIMUM - 1, "wall_s": wall})
    out["williams_toggle"] = rows
    return out


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description="Literature cases: convergence studies, or the references.")
    parser.add_argument("--references", action="store_true", help="recompute the continuum references")
    if parser.parse_args().references:
        print("arch", arch_limit_reference())
        print("bend", bend_reference())
        print("follower", follower_reference())
        print("toggle", toggle_reference())
        print("pinned arch", pinned_arch_reference())
        sys.exit(0)
    results = study()
    print(json.dumps(results, indent=1))
    (ROOT / "benchmarks" / "results" / "literature_cases.json").write_text(json.dumps(results, indent=1) + "\n")
