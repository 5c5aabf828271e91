"""Benchmark problems: run a scene from examples/benchmarks/ and compare with benchmarks.json.

Each ``check_*`` function runs one problem (mesh and step overridable) and returns a
dict ``{"rows": [(quantity, reference, latdyn, error, tolerance), ...], "elements": n,
"dt": dt, "wall_s": s, "result": Result}``.  tests/test_benchmarks.py asserts the rows;
benchmarks/verification_report.py tabulates them.  Nothing here is tuned toward the
reference: meshes and steps are chosen by the convergence studies in this folder.
"""
from __future__ import annotations

import copy
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import yaml

import latdyn

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "examples" / "benchmarks"
#: the published reference numbers, kept in the repository (benchmarks/references/README.md
#: says where each comes from); LATDYN_BENCHMARKS_JSON points elsewhere
REFERENCES = ROOT / "benchmarks" / "references" / "benchmarks.json"


def reference(problem_id: str) -> dict:
    """The problem of benchmarks.json whose id starts with ``problem_id``."""
    env = os.environ.get("LATDYN_BENCHMARKS_JSON")
    path = Path(env) if env else REFERENCES
    for p in json.loads(path.read_text())["problems"]:
        if p["id"].startswith(problem_id):
            return p
    raise KeyError(f"{path}: no problem whose id starts with {problem_id!r}")


def scene(name: str) -> dict:
    s = yaml.safe_load((SCENES / name).read_text())
    return s


def run(s: dict):
    t0 = time.perf_counter()
    r = latdyn.run(copy.deepcopy(s), out_dir=None)
    return r, time.perf_counter() - t0


def _rel(a, b):
    return abs(a - b) / abs(b)


def crossings(t, y, direction=+1):
    """Times where y crosses zero in the given direction (linear interpolation)."""
    t, y = np.asarray(t), np.asarray(y)
    s = np.sign(y)
    idx = np.where((s[:-1] * direction < 0) & (s[1:] * direction >= 0))[0] if direction > 0 else \
        np.where((s[:-1] > 0) & (s[1:] <= 0))[0]
    return np.array([t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i]) for i in idx])


def first_crossing(t, y, level):
    t, y = np.asarray(t), np.asarray(y)
    i = np.where((y[:-1] - level) * (y[1:] - level) <= 0)[0][0]
    return t[i] + (level - y[i]) * (t[i + 1] - t[i]) / (y[i + 1] - y[i]), i


# ---------------------------------------------------------------- L1
def check_L1(elements=8, elements_ff=16):
    ref = reference("L1")["reference"]
    tol = reference("L1")["tolerance"]
    rows, wall = [], 0.0
    for name, key, n, skip in (("clamped-free", "betaL_clamped_free", elements, 0),
                               ("free-free", "betaL_free_free_and_clamped_clamped", elements_ff, None)):
        s = scene("L1_clamped_free.yaml" if skip == 0 else "L1_free_free.yaml")
        s["beams"]["beam"]["elements"] = n
        r, w = run(s)
        wall += w
        omega = 2 * np.pi * np.asarray(r.modes)  # L = EI = rhoA = 1: omega = (betaL)^2
        for k in range(3):
            exact = ref[key][k] ** 2
            got = omega[np.argmin(abs(omega - exact))]
            rows.append((f"{name} omega_{k + 1} (n={n})", exact, float(got), _rel(got, exact),
                         tol["rel_modes_1_2"] if k < 2 else tol["rel_mode_3"]))
    return {"rows": rows, "elements": f"{elements} / {elements_ff}", "dt": "-", "wall_s": wall}


def l1_frequencies(elements, free_free=False):
    s = scene("L1_free_free.yaml" if free_free else "L1_clamped_free.yaml")
    s["beams"]["beam"]["elements"] = elements
    r, _ = run(s)
    return 2 * np.pi * np.asarray(r.modes)


# ---------------------------------------------------------------- L5
def check_L5(elements=32, dt=0.005):
    ref = reference("L5")
    tol = ref["tolerance"]["rel"]
    s = scene("L5_steady_spin.yaml")
    s["beams"]["arm"]["elements"] = elements
    s["solve"]["dt"] = dt
    r, wall = run(s)
    t = np.asarray(r.t)
    window = t >= 0.2
    stretch = float(np.mean(np.asarray(r.probes["stretch"])[window]))
    n1 = float(np.mean(np.asarray(r.probes["N_first"])[window]))
    L, h, rhoA, Om = 10.0, 10.0 / elements, 1.2, 6.0
    n_mid = rhoA * Om ** 2 * (L ** 2 - (h / 2) ** 2) / 2  # N(x) at the first element's middle
    u_ref = ref["reference_kane_beam_Omega6"]["u_tip_stretched_m"]
    rows = [("tip stretch [m]", u_ref, stretch, _rel(stretch, u_ref), tol),
            (f"N first element (x = {h / 2:g}) [N]", n_mid, n1, _rel(n1, n_mid), tol)]
    return {"rows": rows, "elements": elements, "dt": dt, "wall_s": wall, "result": r}


# ---------------------------------------------------------------- S1
def check_S1(elements=96, steps=20):
    ref = reference("S1")
    tol = ref["tolerance"]["abs_tip_position_over_L"]
    s = scene("S1_end_moment_circle.yaml")
    s["beams"]["beam"]["elements"] = elements
    s["solve"]["steps"] = steps
    r, wall = run(s)
    lf = np.asarray(r.t)
    rows = []
    for key, val in ref["reference"].items():
        i = int(np.argmin(abs(lf - float(key))))
        assert abs(lf[i] - float(key)) < 1e-9, "load factor not recorded"
        x, y = r.probes["tip_x"][i], r.probes["tip_y"][i]
        ex, ey = 1 + val["u_axial_over_L"], val["v_transverse_over_L"]
        err = math.hypot(x - ex, y - ey)
        rows.append((f"tip at M/M0 = {key}: |dx| (ref x, y = {ex:.4f}, {ey:.4f})", 0.0, err, err, tol))
    return {"rows": rows, "elements": elements, "dt": f"{steps} load steps", "wall_s": wall, "result": r}


def s1_tip_error(elements, formulation="default"):
    s = scene("S1_end_moment_circle.yaml")
    s["beams"]["beam"]["elements"] = elements
    s["solve"]["formulation"] = formulation
    r, _ = run(s)
    return math.hypot(r.probes["tip_x"][-1], r.probes["tip_y"][-1])


# ---------------------------------------------------------------- S2
def check_S2(elements=32, alphas=("0.25", "0.5", "1", "1.5", "2", "2.5", "3", "3.5", "4")):
    ref = reference("S2")
    tol = ref["tolerance"]["rel"]
    r, wall = s2_run(elements)
    lf = np.asarray(r.t)
    rows = []
    for a in alphas:
        i = int(np.argmin(abs(4 * lf - float(a))))
        assert abs(4 * lf[i] - float(a)) < 1e-9
        v = ref["reference_by_alpha"][a]
        u = 1 - r.probes["tip_x"][i]
        w = r.probes["tip_y"][i]
        rot = math.atan2(r.probes["stub_y"][i] - w, r.probes["stub_x"][i] - r.probes["tip_x"][i])
        rows.append((f"alpha={a} v/L", v["transverse_over_L"], w, _rel(w, v["transverse_over_L"]), tol))
        rows.append((f"alpha={a} u/L", v["axial_shortening_over_L"], u, _rel(u, v["axial_shortening_over_L"]), tol))
        rows.append((f"alpha={a} tip rotation", v["tip_rotation_rad"], rot, _rel(rot, v["tip_rotation_rad"]), tol))
    return {"rows": rows, "elements": elements, "dt": "16 load steps", "wall_s": wall, "result": r}


def s2_run(elements):
    s = scene("S2_elastica_tip_force.yaml")
    s["beams"]["beam"]["elements"] = elements
    return run(s)


# ---------------------------------------------------------------- D1
def period_from(t, y, t_from=0.0):
    t, y = np.asarray(t), np.asarray(y)
    keep = t >= t_from
    t, y = t[keep], y[keep] - np.mean(y[keep])
    up = crossings(t, y, +1)
    return float(np.mean(np.diff(up))), up


def check_D1_constant(elements=8, dt=0.005, t_end=4.5):
    ref = reference("D1")["reference_derived"]["post_ramp_oscillation_period_s"]
    s = scene("D1_constant_spin.yaml")
    s["beams"]["arm"]["elements"] = elements
    s["solve"].update(dt=dt, t_end=t_end)
    r, wall = run(s)
    T, _ = period_from(r.t, r.probes["tip_y"])
    return {"rows": [("period at constant 6 rad/s [s]", ref, T, _rel(T, ref), 0.01)],
            "elements": elements, "dt": dt, "wall_s": wall, "result": r}


def check_D1_full(elements=8, dt=0.005):
    d1 = reference("D1")
    ref = d1["reference_derived"]
    s = scene("D1_spinup.yaml")
    s["beams"]["arm"]["elements"] = elements
    s["solve"]["dt"] = dt
    r, wall = run(s)
    t = np.asarray(r.t)
    tip = np.asarray(r.probes["tip_v"])
    T, _ = period_from(t, tip, 15.0)
    stretch = float(np.mean(np.asarray(r.probes["stretch"])[t >= 15]))
    u_ref = ref["u_axial_tip_m"]
    rows = [("period after 15 s [s]", ref["post_ramp_oscillation_period_s"], T,
             _rel(T, ref["post_ramp_oscillation_period_s"]), 0.01),
            ("max |tip v| [m] (bounded)", 0.0, float(np.max(abs(tip))), float(np.max(abs(tip))), 1.0),
            ("mean tip stretch after 15 s vs L5 [m]", u_ref, stretch, _rel(stretch, u_ref), 0.02)]
    return {"rows": rows, "elements": elements, "dt": dt, "wall_s": wall, "result": r}


def run_D1_no_stiffening(elements=8, dt=0.005, t_end=12.0):
    """Returns (result or None, error message or None, time of divergence, wall)."""
    s = scene("D1_spinup_no_stiffening.yaml")
    s["beams"]["arm"]["elements"] = elements
    s["solve"].update(dt=dt, t_end=t_end)
    t0 = time.perf_counter()
    try:
        r = latdyn.run(copy.deepcopy(s), out_dir=None)
        err = None
    except latdyn.errors.SolverError as e:  # pragma: no cover - depends on the run
        r, err = None, str(e)
    return r, err, time.perf_counter() - t0


# ---------------------------------------------------------------- D2
def check_D2(elements=10, dt=0.05, t_end=30.0):
    d2 = reference("D2")
    ref, tol = d2["reference"], d2["tolerance"]
    s = scene("D2_right_angle_cantilever.yaml")
    s["beams"]["leg1"]["elements"] = s["beams"]["leg2"]["elements"] = elements
    s["solve"].update(dt=dt, t_end=t_end)
    r, wall = run(s)
    t = np.asarray(r.t)
    tip, elbow = np.asarray(r.probes["tip_u3"]), np.asarray(r.probes["elbow_u3"])
    rows = []
    early = t <= 10
    i = int(np.argmax(np.where(early, tip, -np.inf)))
    rows.append(("tip max value", ref["tip_max"][1], tip[i], _rel(tip[i], ref["tip_max"][1]), tol["rel_amplitude"]))
    rows.append(("tip max time [s]", ref["tip_max"][0], t[i], abs(t[i] - ref["tip_max"][0]), tol["abs_time_s"]))
    window = (t > 10) & (t <= 20)
    if window.any():
        j = int(np.argmin(np.where(window, tip, np.inf)))
        rows.append(("tip min value", ref["tip_min"][1], tip[j], _rel(tip[j], ref["tip_min"][1]), tol["rel_amplitude"]))
        rows.append(("tip min time [s]", ref["tip_min"][0], t[j], abs(t[j] - ref["tip_min"][0]), tol["abs_time_s"]))
    k = int(np.argmax(np.where(t <= 6, elbow, -np.inf)))
    rows.append(("elbow first max", ref["elbow_first_max"][1], elbow[k],
                 _rel(elbow[k], ref["elbow_first_max"][1]), tol["rel_amplitude"]))
    rows.append(("elbow first max time [s]", ref["elbow_first_max"][0], t[k], abs(t[k] - ref["elbow_first_max"][0]),
                 tol["abs_time_s"]))
    e = np.asarray(r.probes["energy"])
    after = t >= 2.0
    drift = float(np.max(abs(e[after] - e[after][0])) / abs(e[after][0]))
    rows.append(("energy drift after 2 s (rel)", 0.0, drift, drift, tol["energy_drift_after_t2"]))
    return {"rows": rows, "elements": 2 * elements, "dt": dt, "wall_s": wall, "result": r}


# ---------------------------------------------------------------- D3
def check_D3(elements=10, dt=0.01, t_end=7.0):
    d3 = reference("D3")
    inv, tol = d3["reference_invariants"], d3["tolerance"]
    s = scene("D3_flying_spaghetti.yaml")
    s["beams"]["spaghetti"]["elements"] = elements
    s["solve"].update(dt=dt, t_end=t_end)
    r, wall = run(s)
    t = np.asarray(r.t)
    px = np.asarray(r.probes["px"])
    after = t >= 5.0 - 1e-9
    p_ref = inv["impulse_F1"]
    p_err = float(np.max(abs(px[after] - p_ref)) / p_ref)
    # centre of mass from the momentum: x_cm(t) - x_cm(0) = int p dt / m (trapezoid, exact
    # for the integrator's piecewise-linear velocity only to O(h^2))
    xcm = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (px[1:] + px[:-1]))]) / inv["mass"]
    i5 = int(np.argmin(abs(t - 5.0)))
    rows = [("linear momentum x after 5 s", p_ref, float(px[after][-1]), p_err, tol["rel_cm"]),
            ("cm displacement x at 5 s (from momentum)", inv["cm_displacement_X_at_5s"], float(xcm[i5]),
             _rel(xcm[i5], inv["cm_displacement_X_at_5s"]), tol["rel_cm"]),
            ("cm displacement x at end", 12.5 + 5 * (t[-1] - 5), float(xcm[-1]),
             _rel(xcm[-1], 12.5 + 5 * (t[-1] - 5)), tol["rel_cm"])]
    for comp in ("py", "pz"):
        v = float(np.max(abs(np.asarray(r.probes[comp]))))
        rows.append((f"linear momentum {comp[1]} (0)", 0.0, v, v / p_ref, tol["rel_cm"]))
    Lvec = np.stack([np.asarray(r.probes[c]) for c in ("Lx", "Ly", "Lz")])[:, after]
    scale = float(np.max(np.linalg.norm(Lvec, axis=0)))  # drift relative to |L|
    for comp in ("Lx", "Ly", "Lz"):
        L = np.asarray(r.probes[comp])[after]
        rows.append((f"angular momentum {comp[1]} drift after 5 s / |L|", 0.0, float(np.ptp(L) / scale),
                     float(np.ptp(L) / scale), tol["energy_drift"]))
    e = np.asarray(r.probes["energy"])[after]
    drift = float(np.ptp(e) / abs(e[0]))
    rows.append(("energy drift after 5 s (rel)", 0.0, drift, drift, tol["energy_drift"]))
    return {"rows": rows, "elements": elements, "dt": dt, "wall_s": wall, "result": r}


# ---------------------------------------------------------------- D4
def check_D4_rigid(elements=4, dt=0.001):
    ref = reference("D4")["reference_rigid_limit"]
    s = scene("D4_rigid_limit.yaml")
    s["beams"]["pendulum"]["elements"] = elements
    s["solve"]["dt"] = dt
    r, wall = run(s)
    t, ang, rate = np.asarray(r.t), np.asarray(r.probes["angle"]), np.asarray(r.probes["rate"])
    tv, i = first_crossing(t, ang, -math.pi / 2)
    w = abs(rate[i] + (rate[i + 1] - rate[i]) * (tv - t[i]) / (t[i + 1] - t[i]))
    rows = [("time to vertical [s]", ref["time_to_vertical_s"], tv, _rel(tv, ref["time_to_vertical_s"]), 1e-3),
            ("rate at vertical [rad/s]", ref["omega_at_vertical_rad_s"], w, _rel(w, ref["omega_at_vertical_rad_s"]),
             1e-3)]
    return {"rows": rows, "elements": elements, "dt": dt, "wall_s": wall, "result": r}


def check_D4_energy(elements=8, dt=0.001, t_end=0.4):
    tol = reference("D4")["tolerance"]["energy_drift"]
    s = scene("D4_flexible_pendulum.yaml")
    s["beams"]["pendulum"]["elements"] = elements
    s["solve"].update(dt=dt, t_end=t_end)
    r, wall = run(s)
    e = np.asarray(r.probes["energy"])
    scale = float(np.max(abs(np.asarray(r.probes["potential"]))))  # energy exchanged
    drift = float(np.max(abs(e - e[0])) / scale)
    rows = [("energy drift / max |potential|", 0.0, drift, drift, tol)]
    return {"rows": rows, "elements": elements, "dt": dt, "wall_s": wall, "result": r}


def check_D4_published(elements=8, dt=0.00025, t_end=1.0):
    """D4 as published (ρI = 0) with 8 elements through 1 s: the scene is planar, so it runs with
    in-plane coordinates (solve.planar: auto); the 3D model of it fails near 0.45 s
    (docs/verification.md). The drift is Newmark's, second order in dt: 4.0e-4 at 1 ms,
    1.0e-4 at 0.5 ms, 2.5e-5 at 0.25 ms."""
    tol = reference("D4")["tolerance"]["energy_drift"]
    s = scene("D4_flexible_pendulum.yaml")
    s["beams"]["pendulum"]["elements"] = elements
    s["solve"].update(dt=dt, t_end=t_end, planar="auto")
    r, wall = run(s)
    t = np.asarray(r.t)
    e = np.asarray(r.probes["energy"])
    scale = float(np.max(abs(np.asarray(r.probes["potential"]))))
    drift = float(np.max(abs(e - e[0])) / scale)
    rows = [("completed to t_end [s]", t_end, float(t[-1]), abs(t[-1] - t_end), 1e-9),
            ("energy drift / max |potential|", 0.0, drift, drift, tol)]
    return {"rows": rows, "elements": elements, "dt": dt, "wall_s": wall, "result": r}


# ---------------------------------------------------------------- D5
def check_D5(elements=4, dt=0.004, t_end=2.0):
    s = scene("D5_fourbar.yaml")
    for b in ("bar1", "bar2", "bar3"):
        s["beams"][b]["elements"] = elements
    s["solve"].update(dt=dt, t_end=t_end)
    r, wall = run(s)
    p = {k: np.asarray(v) for k, v in r.probes.items()}
    t = np.asarray(r.t)
    # parallelogram: rocker angle = crank angle; BC stays parallel to AD and 0.24 long
    rocker_err = float(np.max(abs(p["rocker"] - p["crank"])))
    bc = np.hypot(p["Cx"] - p["Bx"], p["Cy"] - p["By"])
    bc_err = float(np.max(abs(bc - 0.24)) / 0.24)
    b_radius = float(np.max(abs(np.hypot(p["Bx"], p["By"]) - 0.12)) / 0.12)
    rows = [("completed to t_end [s]", t_end, float(t[-1]), abs(t[-1] - t_end), 1e-9),
            ("max |rocker - crank| [rad]", 0.0, rocker_err, rocker_err, 0.01),
            ("max | |BC| - 0.24 | / 0.24", 0.0, bc_err, bc_err, 1e-3),
            ("max | |AB| - 0.12 | / 0.12", 0.0, b_radius, b_radius, 1e-3),
            ("max |z of C| [m] (out of plane)", 0.0, float(np.max(abs(p["Cz"]))), float(np.max(abs(p["Cz"]))), 0.01)]
    return {"rows": rows, "elements": 3 * elements, "dt": dt, "wall_s": wall, "result": r}
