"""Issue 32's checks measured: each against its exact reference, beside the tolerance its test asserts.

Run from the repository root::

    python benchmarks/issue32_checks.py            # the check table (about a minute)
    python benchmarks/issue32_checks.py --peak     # a Hertz stop's peak load against the step size
    python benchmarks/issue32_checks.py --costs    # with and without cables, friction, a compliant stop
    python benchmarks/issue32_checks.py --chatter  # the damped cable truss's changes against dt and c (minutes)

Each check runs the scene its test runs (the scene texts and references are imported from the test
modules, so that the table and the suite measure one thing) through ``latdyn.run(latdyn.load_scene(...))``
and prints, for each quantity, the reference, latdyn's value, the error and the tolerance the test
asserts (``tests/FILE::TEST``). The results go to ``benchmarks/results/issue32_checks.json``
(``issue32_costs.json``, ``issue32_peak.json``); docs/cables.md, docs/contact.md and docs/guides.md
quote them.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import latdyn  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"


def run(text: str):
    """A scene typed as YAML, written to a file and run through the API (``latdyn.load_scene(path)``,
    whose reader keeps the key ``on`` a word)."""
    path = Path("scene.yaml")
    path.write_text(text)
    return latdyn.run(latdyn.load_scene(str(path)))


def row(check, quantity, reference, value, error, tolerance, test):
    return {"check": check, "quantity": quantity, "reference": float(reference), "latdyn": float(value),
            "error": float(error), "tolerance": float(tolerance), "test": test}


# -- cables ---------------------------------------------------------------------------------------------

def check_drop(direction, offset, fall, label, test):
    """A mass dropped on a slack massless cable: taut at √(2h/g), the peak stretch and tension, the slack
    time, the total energy across the events."""
    from test_cables import REST, drop_reference, drop_scene

    ref = drop_reference(fall)
    r = run(drop_scene(direction, offset, fall))
    events = r.summary["cable_events"]
    t, N, x, E, K = (np.asarray(v) for v in (r.t, r.probes["N"], r.probes["x"], r.probes["E"], r.probes["K"]))
    stretch = x.max() - offset - REST
    peak = int(np.argmax(N))
    return [
        row(label, "taut time (s)", ref["t_taut"], events[0]["t"], abs(events[0]["t"] - ref["t_taut"]), 3e-10, test),
        row(label, "peak tension (rel.)", ref["tension"], N[peak], abs(N[peak] / ref["tension"] - 1), 5e-5, test),
        row(label, "peak stretch (m)", ref["delta"], stretch, abs(stretch - ref["delta"]), 5e-6 * (REST + ref["delta"]),
            test),
        row(label, "slack time (s)", ref["t_slack"], events[1]["t"], abs(events[1]["t"] - ref["t_slack"]), 2e-5, test),
        row(label, "total energy across the events (of max kinetic)", 0.0, np.abs(E - E[0]).max() / K.max(),
            np.abs(E - E[0]).max() / K.max(), 2e-4, test),
        row(label, "energy_balance_error", 0.0, r.summary["energy_balance_error"],
            r.summary["energy_balance_error"], 1e-4, test),
    ]


def check_string(axis, test):
    """A taut string by pretension: fₙ = (n/2L)√(T/μ) from ``modes, about: static``."""
    from test_cables import string_scene

    text, T, mu = string_scene(axis)
    r = run(text)
    frequencies = np.asarray(r.modes)[:6]
    n, L = 20, 2.0
    m, h = mu * (L / (1 + 1e-3)) / n, L / n
    rows = []
    for i, k in enumerate((1, 1, 2, 2, 3, 3)):
        if i % 2:
            continue
        lumped = 2 * math.sqrt(T / (m * h)) * math.sin(k * math.pi / (2 * n)) / (2 * math.pi)
        exact = k / (2 * L) * math.sqrt(T / mu)
        pair = frequencies[i:i + 2]
        rows.append(row(f"taut string, axis {axis}", f"f{k}, both planes, vs (n/2L)√(T/μ) (rel.)", exact, pair[0],
                        np.abs(pair / exact - 1).max(), 1e-2, test))
        rows.append(row(f"taut string, axis {axis}", f"f{k} vs the lumped string's exact (rel.)", lumped, pair[0],
                        np.abs(pair / lumped - 1).max(), 2e-11, test))
    return rows


def check_catenary(span_vector, test):
    """Irvine's elastic catenary: the midspan sag and the support tension (static, 20 elements)."""
    from test_cables import brent, catenary_scene

    r = run(catenary_scene(span_vector))
    sag, N = -float(r.probes["sag"][-1]), float(r.probes["N"][-1])
    span, L0, EA, w, n = 10.0, 9.99, 1.0e4, 9.81, 20
    P = w * L0 / n

    def chain(H):
        V = (n - 1) * P / 2 - np.arange(n) * P
        T = np.hypot(H, V)
        return L0 / n * (1 + T / EA), V, T

    H = brent(lambda H: np.sum(chain(H)[0] * H / chain(H)[2]) - span, 1.0, 1e5)
    ell, V, T = chain(H)
    chain_sag = float(np.sum((ell * V / T)[: n // 2]))
    Vc = w * L0 / 2
    Hc = brent(lambda H: H * L0 / EA + 2 * H / w * np.arcsinh(Vc / H) - span, 1.0, 1e5)
    irvine_sag = L0 / (2 * EA) * (Vc - w * L0 / 4) + Hc / w * (np.sqrt(1 + (Vc / Hc) ** 2) - 1)
    label = f"elastic catenary, span {span_vector}"
    return [
        row(label, "midspan sag vs Irvine (rel.)", irvine_sag, sag, abs(sag / irvine_sag - 1), 1.5e-3, test),
        row(label, "support tension vs Irvine (rel.; first element's)", math.hypot(Hc, Vc), N,
            abs(N / math.hypot(Hc, Vc) - 1), 1e-2, test),
        row(label, "sag vs the lumped chain's exact statics (rel.)", chain_sag, sag, abs(sag / chain_sag - 1), 1e-13,
            test),
        row(label, "tension vs the lumped chain's (rel.)", T[0], N, abs(N / T[0] - 1), 1e-13, test),
    ]


# -- guides ---------------------------------------------------------------------------------------------

def check_bead(text, label, test):
    """A bead on a frictionless rod turning at Ω = 2: r = r₀ cosh Ωt."""
    r = run(text)
    t, radius = np.asarray(r.t), np.asarray(r.probes["r"])
    r0 = radius[0]
    exact = r0 * np.cosh(2.0 * t)
    error = np.abs(radius - exact).max() / exact.max()
    return [row(label, "r(t) vs r₀ cosh Ωt (of max r)", exact[-1], radius[-1], error, 1.5e-5, test)]


def check_rigid_slider_crank(test):
    from test_slider_crank import exact_slide, rigid_slider_crank

    r = run(rigid_slider_crank())
    x, t = np.asarray(r.probes["x"]), np.asarray(r.t)
    error = np.abs(x - exact_slide(10.0 * t)).max()
    return [row("rigid slider-crank, prescribed crank", "slider position (m)", exact_slide(10.0 * t[-1]), x[-1],
                error, 1e-14, test)]


def check_flexible_slider_crank(test):
    from test_slider_crank import FLEXIBLE_SLIDER_CRANK, deflection, reference

    r = run(FLEXIBLE_SLIDER_CRANK)
    point = {n: np.column_stack([r.probes[f"{n}_x"], r.probes[f"{n}_y"], 0.0 * np.asarray(r.t)])
             for n in ("pin", "mid", "end")}
    d = deflection(point["pin"], point["mid"], point["end"], np.array([0.0, 0.0, 1.0]))
    _, d_ref, _ = reference()
    peak = np.abs(d_ref).max()
    return [row("flexible slider-crank (8 el., dt 1e-4)", "mid-span deflection vs Exudyn (of its peak)", peak,
                np.abs(d).max(), np.abs(d - d_ref).max() / peak, 4e-3, test)]


# -- contact and friction -------------------------------------------------------------------------------

def hertz_panel(dt, axis=(0, 0, 1), damping=0.0):
    """The hinged panel of tests/test_contact.py (inertia 2 about ``axis``) on a Hertz stop (n = 3/2,
    k = 1000) at 0.1 rad, turning at v = 1 rad/s."""
    from test_contact import panel_about

    contact = "stiffness: 1000.0, exponent: 1.5" + (f", damping: {damping}" if damping else "")
    return panel_about(axis, f"limits: [-1, 0.1], contact: {{{contact}}}", dt=dt)


def hertz_reference(I=2.0, k=1000.0, n=1.5, v=1.0):
    from scipy.special import beta

    peak = ((n + 1) * I * v * v / (2 * k)) ** (1 / (n + 1))
    return peak, k * peak ** n, 2 * peak / v * beta(1 / (n + 1), 0.5) / (n + 1)


def measure_hertz(dt, axis=(0, 0, 1)):
    from test_contact import contact_interval

    r = run(hertz_panel(dt, axis))
    depth = np.asarray(r.probes["angle"]) - 0.1
    peak, load, contact_time = hertz_reference()
    t = np.asarray(r.t)
    on, off = contact_interval(t, depth)
    i = int(np.argmax(depth))  # the vertex of the parabola through the rows about the peak: the step's own peak
    c2, c1, c0 = np.polyfit(t[i - 1:i + 2] - t[i], depth[i - 1:i + 2], 2)
    vertex = c0 - c1 * c1 / (4 * c2)
    reported = abs(r.summary["joint_peaks"]["arm.start"]["peak"])  # the stop's torque, summary.json
    return {"dt": dt, "steps_in_contact": int(np.sum(depth > 0)), "peak_penetration": depth.max() / peak - 1,
            "peak_load": 1000.0 * depth.max() ** 1.5 / load - 1, "joint_peaks": reported / load - 1,
            "peak_load_between_rows": 1000.0 * vertex ** 1.5 / load - 1,
            "contact_time": (off - on) / contact_time - 1, "rebound": float(r.probes["rate"][-1]), "onset": on - 0.1}


def check_hertz(axis, label, test):
    m = measure_hertz(0.002, axis)
    peak, load, contact_time = hertz_reference()
    return [
        row(label, "peak penetration ((n+1)Iv²/2k)^(1/(n+1)) (rel.)", peak, peak * (1 + m["peak_penetration"]),
            abs(m["peak_penetration"]), 2e-4, test),
        row(label, "peak load k δⁿ (rel.)", load, load * (1 + m["peak_load"]), abs(m["peak_load"]), 3e-4, test),
        row(label, "contact time (rel.)", contact_time, contact_time * (1 + m["contact_time"]),
            abs(m["contact_time"]), 2e-4, test),
        row(label, "rebound rate (rad/s)", -1.0, m["rebound"], abs(m["rebound"] + 1.0), 1e-5, test),
        row(label, "contact onset (s)", 0.1, 0.1 + m["onset"], abs(m["onset"]), 1e-7, test),
    ]


def check_hunt_crossley(axis, label, test):
    from scipy.integrate import solve_ivp

    I, k, n, c, v = 2.0, 1000.0, 1.5, 300.0, 1.0
    r = run(hertz_panel(0.002, axis, damping=c))

    def motion(_, y):
        d, rate = y
        force = max(k * max(d, 0.0) ** n + c * max(d, 0.0) ** n * rate, 0.0)
        return [rate, -force / I]

    def separated(_, y):
        return y[0]

    separated.terminal, separated.direction = True, -1
    ode = solve_ivp(motion, (0.0, 1.0), [1e-14, v], events=separated, rtol=1e-11, atol=1e-14, max_step=1e-3)
    rebound, peak = ode.y_events[0][0][1], ode.y[0].max()
    got_rebound, got_peak = float(r.probes["rate"][-1]), float(np.max(r.probes["angle"]) - 0.1)
    lost = 0.5 * I * (v * v - rebound * rebound)
    dissipated = float(r.probes["dissipated"][-1])
    return [
        row(label, "rebound rate vs solve_ivp (rel.)", rebound, got_rebound, abs(got_rebound / rebound - 1), 2e-4,
            test),
        row(label, "peak penetration vs solve_ivp (rel.)", peak, got_peak, abs(got_peak / peak - 1), 2e-4, test),
        row(label, "dissipated vs kinetic energy lost (rel.)", lost, dissipated, abs(dissipated / lost - 1), 1e-3,
            test),
    ]


def check_coulomb(axis, label, test):
    from test_contact import coulomb_oscillator, turning_points

    I, k, F, A0 = 0.01, 1.0, 0.1, 0.45
    r = run(coulomb_oscillator(list(axis)))
    t, rate = np.asarray(r.t), np.asarray(r.probes["rate"])
    x = np.asarray(r.probes["angle"]) - A0
    times, values = turning_points(t, x, rate)
    half = math.pi * math.sqrt(I / k)
    periods = np.diff(np.concatenate([[0.0], times[:2]]))
    return [
        row(label, "first half cycle's amplitude A0 − 2F/k (rad)", A0 - 2 * F / k, abs(values[0]),
            abs(abs(values[0]) - (A0 - 2 * F / k)), 5e-4, test),
        row(label, "after a cycle A0 − 4F/k (rad)", A0 - 4 * F / k, abs(values[1]),
            abs(abs(values[1]) - (A0 - 4 * F / k)), 5e-4, test),
        row(label, "half period π√(I/k) (rel., worst of two)", half, periods[np.argmax(np.abs(periods / half - 1))],
            np.abs(periods / half - 1).max(), 3e-3, test),
        row(label, "rest angle, |θ| ≤ F/k (rad)", -(A0 - 4 * F / k), x[-1], abs(x[-1] + (A0 - 4 * F / k)), 5e-4,
            test),
    ]


def checks():
    from test_guides import BEAD

    planar_bead = BEAD.replace("axis: [1, 1, 1]", "axis: [0, 0, 1]")
    rows = []
    contact = "tests/test_contact.py::"
    runs = [
        lambda: check_drop([0, -1, 0], 0.0, 0.8, "mass dropped on a slack cable, planar",
                           "tests/test_cables.py::test_mass_dropped_on_a_slack_cable_planar_through_the_cli"),
        lambda: check_drop([1.0, -2.0, 2.0], 0.05, 0.7, "mass dropped on a slack cable, 3D",
                           "tests/test_cables.py::test_mass_dropped_on_a_slack_cable_in_3d_through_the_api"),
        lambda: check_bead(BEAD, "bead on a rod turning at Ω, 3D",
                           "tests/test_guides.py::test_bead_on_a_turning_rod_follows_cosh"),
        lambda: check_bead(planar_bead, "bead on a rod turning at Ω, planar",
                           "tests/test_guides.py::test_bead_on_a_rod_turning_in_its_plane_through_the_cli"),
        lambda: check_rigid_slider_crank(
            "tests/test_slider_crank.py::test_rigid_slider_crank_with_a_prescribed_crank_follows_the_exact_kinematics"),
        lambda: check_flexible_slider_crank(
            "tests/test_slider_crank.py::test_flexible_slider_crank_mid_span_deflection_against_exudyn"),
        lambda: check_string([1, 0, 0], "tests/test_cables.py::test_taut_string_modes_about_the_pretensioned_state"),
        lambda: check_string([1, 2, -2], "tests/test_cables.py::test_taut_string_modes_about_the_pretensioned_state"),
        lambda: check_catenary([10.0, 0.0, 0.0], "tests/test_cables.py::test_elastic_catenary_static"),
        lambda: check_catenary([6.0, 0.0, 8.0], "tests/test_cables.py::test_elastic_catenary_static"),
        lambda: check_hertz((0, 0, 1), "Hertz stop, planar", contact + "test_a_panel_on_a_hertz_stop_through_the_cli"),
        lambda: check_hertz((2, -1, 2), "Hertz stop, 3D",
                            "tests/test_contact.py::test_a_panel_on_a_hertz_stop_about_a_skew_axis_through_the_api"),
        lambda: check_hunt_crossley((0, 0, 1), "Hunt–Crossley rebound, planar",
                                    contact + "test_hunt_crossley_rebound_against_an_independent_integration"),
        lambda: check_hunt_crossley((2, -1, 2), "Hunt–Crossley rebound, 3D",
                                    contact + "test_hunt_crossley_rebound_against_an_independent_integration"),
        lambda: check_coulomb((0, 0, 1), "Coulomb torsional oscillator, planar",
                              contact + "test_a_torsional_oscillator_with_coulomb_friction_through_the_cli"),
        lambda: check_coulomb((2, -1, 2), "Coulomb torsional oscillator, 3D",
                              contact + "test_a_torsional_oscillator_with_coulomb_friction_on_a_skew_axis_through_the_api"),
    ]
    for one in runs:
        rows.extend(one())
    return rows


# -- the peak load against the step ---------------------------------------------------------------------

def peak_against_step():
    return [measure_hertz(dt) for dt in (0.008, 0.004, 0.002, 0.001, 0.0005, 0.00025)]


# -- costs ----------------------------------------------------------------------------------------------

def load_average():
    try:
        return os.getloadavg()[0]
    except OSError:
        return float("nan")


def cost_of(scene: dict, repeats: int):
    """Median process CPU time of ``repeats`` in-process runs (after one that compiles), and the counts."""
    latdyn.run(latdyn.load_scene(json.loads(json.dumps(scene))))
    times, loads = [], []
    for _ in range(repeats):
        loads.append(load_average())
        s = latdyn.load_scene(json.loads(json.dumps(scene)))
        c0 = time.process_time()
        r = latdyn.run(s)
        times.append(time.process_time() - c0)
    s = r.summary
    steps = s["steps"]
    return {"cpu_s": statistics.median(times), "cpu_s_min": min(times), "steps": steps,
            "newton_iterations": s["newton_iterations"], "rejected_steps": s["rejected_steps"],
            "cpu_ms_per_step": 1e3 * statistics.median(times) / steps,
            "iterations_per_step": s["newton_iterations"] / steps,
            "events": len(s.get("events", [])), "load": statistics.median(loads), "status": s["status"]}


def cost_pairs():
    """Each pair: the same structure and step, with the feature and without it."""
    examples = ROOT / "examples"
    truss = yaml.safe_load((examples / "deploying_truss.yaml").read_text())
    cabled = yaml.safe_load((examples / "cable_deploying_truss.yaml").read_text())
    for s in (truss, cabled):
        s["solve"]["t_end"] = 1.0
        s["output"] = {"every": 0.01, "probes": {"tip_x": {"point": "s3a", "quantity": "position", "component": "x"}}}
    slack = json.loads(json.dumps(cabled))  # the cables never taut: the same steps as without them
    for cable in slack["cables"].values():
        cable["rest_length"] = 3.5
    boom = yaml.safe_load((examples / "deploying_boom.yaml").read_text())
    boom["solve"]["t_end"] = 1.5
    boom["output"]["probes"] = {"hinge": boom["output"]["probes"]["hinge"]}

    def knee(change):
        s = json.loads(json.dumps(boom))
        hinge = s["beams"]["outer"]["start"]["hinge"]
        change(hinge)
        return s

    def friction(h):
        h["friction"] = {"coulomb": 0.05, "static": 0.08}

    def compliant(h):
        del h["lock_at"]
        h["limits"] = [-1.0, "pi"]
        h["contact"] = {"stiffness": 2000.0, "exponent": 1.5, "damping": 200.0}

    def rigid(h):
        del h["lock_at"]
        h["limits"] = [-1.0, "pi"]
        h["restitution"] = 0.3

    return [
        ("truss driven by its hinge springs (deploying_truss.yaml, 1 s)", truss,
         "the same held back by two cables paid out by a reel (cable_deploying_truss.yaml)", cabled),
        ("truss driven by its hinge springs (deploying_truss.yaml, 1 s)", truss,
         "the same with the two cables, slack throughout (rest length 3.5 m)", slack),
        ("boom, knee latch, no friction (deploying_boom.yaml, 1.5 s)", boom,
         "the same knee with Coulomb 0.05, static 0.08 N·m", knee(friction)),
        ("boom, knee on a rigid stop at π (restitution 0.3)", knee(rigid),
         "the same stop compliant: Hertz k 2000, c 200", knee(compliant)),
        ("boom, knee latch (lock_at π)", boom,
         "the same stop compliant: Hertz k 2000, c 200", knee(compliant)),
    ]


def costs(repeats: int):
    out = []
    for without_label, without, with_label, with_ in cost_pairs():
        a = cost_of(without, repeats)
        b = cost_of(with_, repeats)
        out.append({"without": without_label, "with": with_label, "a": a, "b": b})
        print(f"{without_label}\n  {a}\n{with_label}\n  {b}", flush=True)
    return out


# -- the damped cable truss's slack and taut changes ----------------------------------------------------

def damped_truss(dt: float, damping: float, t_end: float = 4.0) -> dict:
    """``examples/cable_deploying_truss.yaml`` with ``damping`` on both cables, run at ``dt``: the count of
    slack and taut changes, the run's counts and energies, and each change (for the JSON)."""
    scene = yaml.safe_load((ROOT / "examples" / "cable_deploying_truss.yaml").read_text())
    for cable in scene["cables"].values():
        cable["damping"] = damping
    scene["solve"].update(dt=dt, t_end=t_end)
    scene["output"] = {"every": 0.01, "probes": {"pull": {"cable": "tie_a", "quantity": "tension"}}}
    c0 = time.process_time()
    s = latdyn.run(latdyn.load_scene(scene)).summary
    changes = s["cable_events"]
    return {"dt": dt, "damping": damping, "changes": len(changes), "steps": s["steps"],
            "newton_iterations": s["newton_iterations"], "rejected_steps": s["rejected_steps"],
            "energy_balance_error": s["energy_balance_error"], "dissipated_energy": s["dissipated_energy"],
            "cpu_s": time.process_time() - c0, "latches": [e["t"] for e in s["events"] if e["kind"] == "latch"],
            "cable_events": [[e["t"], e["cable"], e["state"]] for e in changes]}


def chatter():
    runs = [damped_truss(dt, 50.0) for dt in (2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4)]
    runs += [damped_truss(1e-3, c) for c in (0.0, 5.0, 20.0)]
    print("| c (N·s/m) | dt (s) | slack and taut changes | steps | Newton iterations | rejected | dissipated (J) "
          "| energy balance | CPU (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in runs:
        print(f"| {r['damping']:g} | {r['dt']:g} | {r['changes']} | {r['steps']} | {r['newton_iterations']} "
              f"| {r['rejected_steps']} | {r['dissipated_energy']:.3f} | {r['energy_balance_error']:.1e} "
              f"| {r['cpu_s']:.1f} |")
    return runs


def machine():
    cpu = "unknown"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{os.cpu_count()} cores, {cpu}, Python {platform.python_version()}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--peak", action="store_true", help="a Hertz stop's peak load against the step")
    parser.add_argument("--costs", action="store_true", help="with and without cables, friction, contact")
    parser.add_argument("--chatter", action="store_true", help="the damped cable truss against dt and damping")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    RESULTS.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        if args.peak:
            rows = peak_against_step()
            print("| dt | steps in contact | peak penetration | peak load k δⁿ | `joint_peaks` "
                  "| peak load between the rows | contact time | rebound rate |")
            print("|---|---|---|---|---|---|---|---|")
            for m in rows:
                print(f"| {m['dt']:g} | {m['steps_in_contact']} | {m['peak_penetration']:+.1e} | {m['peak_load']:+.1e} "
                      f"| {m['joint_peaks']:+.1e} | {m['peak_load_between_rows']:+.1e} | {m['contact_time']:+.1e} "
                      f"| {m['rebound']:.7f} |")
            (RESULTS / "issue32_peak.json").write_text(json.dumps({"machine": machine(), "rows": rows}, indent=1))
            return
        if args.chatter:
            runs = chatter()
            (RESULTS / "issue32_chatter.json").write_text(json.dumps({"machine": machine(), "runs": runs},
                                                                     separators=(",", ":")))
            return
        if args.costs:
            rows = costs(args.repeats)
            print("| run | steps | Newton iterations (per step) | rejected | events | CPU ms per step, median | load |")
            print("|---|---|---|---|---|---|---|")
            for pair in rows:
                for label, m in ((pair["without"], pair["a"]), (pair["with"], pair["b"])):
                    print(f"| {label} | {m['steps']} | {m['newton_iterations']} ({m['iterations_per_step']:.2f}) "
                          f"| {m['rejected_steps']} | {m['events']} | {m['cpu_ms_per_step']:.3f} | {m['load']:.1f} |")
            (RESULTS / "issue32_costs.json").write_text(json.dumps({"machine": machine(), "rows": rows}, indent=1))
            return
        t0 = time.perf_counter()
        rows = checks()
        print("| check | quantity | reference | latdyn | error | test's tolerance | test |")
        print("|---|---|---|---|---|---|---|")
        for r in rows:
            flag = "" if r["error"] <= r["tolerance"] else " **FAILS**"
            loose = " (tolerance ≥ 100× the error)" if r["error"] * 100 < r["tolerance"] and r["error"] > 0 else ""
            print(f"| {r['check']} | {r['quantity']} | {r['reference']:.10g} | {r['latdyn']:.10g} | {r['error']:.2g}"
                  f"{flag} | {r['tolerance']:.2g}{loose} | `{r['test']}` |")
        print(f"\n{time.perf_counter() - t0:.1f} s wall, load {load_average():.1f}, {machine()}")
        (RESULTS / "issue32_checks.json").write_text(json.dumps({"machine": machine(), "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
