"""Cables (issue 32 item 1; SCENE.md ``cables``): the generated taut law against central differences,
a mass dropped on a slack cable against the closed form (free fall, the taut event at √(2h/g), the
peak stretch and tension, the slack event, energy conserved across the events), planar and 3D,
through the CLI and the API; a taut string's modes about its pretensioned static state against
fₙ = (n/2L)√(T/μ) (exactly: the lumped string's); slack and taut in summary.json ``events`` with a
latch's; bad values refused with the key named."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns, summary_of
from latdyn.model.kernels import load_kernels
from latdyn.numerics.so3 import expm_so3

RNG = np.random.default_rng(20261126)


def cable_inputs(n=4):
    x = RNG.normal(size=(n, 6))
    offsets = RNG.normal(size=(n, 6)) * 0.3
    velocity = RNG.normal(size=(n, 12))
    length = np.linalg.norm((x[:, 3:6] + offsets[:, 3:6]) - (x[:, 0:3] + offsets[:, 0:3]), axis=1)
    section = np.column_stack([0.9 * length, RNG.normal(size=n), RNG.uniform(10.0, 100.0, n),
                               RNG.uniform(0.5, 2.0, n)])
    return np.concatenate([x, offsets], axis=1), velocity, section


def moved(geometry, k, step):
    """The geometry after coordinate k of [d1, π1, d2, π2] moves by ``step`` (spatial update of the offset)."""
    g = geometry.copy()
    end, slot = divmod(k, 6)
    if slot < 3:
        g[3 * end + slot] += step
    else:
        R = expm_so3(np.eye(3)[slot - 3] * step)
        g[6 + 3 * end:9 + 3 * end] = R @ g[6 + 3 * end:9 + 3 * end]
    return g


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_cable_force_against_differences(backend):
    """cable_force's stiffness (by [d, π] of both ends) and damping (by the rates) against central
    differences of its force; the force against N e by hand; the rest length's generalized force
    against central differences ∂U/∂L0 of the strain energy; the dampers' forces c ℓ̇ and −N_el."""
    ks = load_kernels(backend, "default")
    geometry, velocity, section = cable_inputs()
    force, K, C, state, energy, reel, damper, clipped = ks.cable_force(geometry, velocity, section)
    eps = 1e-6
    for b in range(len(geometry)):
        g, v, s = geometry[b], velocity[b], section[b]
        p1, p2 = g[0:3] + g[6:9], g[3:6] + g[9:12]
        ell = np.linalg.norm(p2 - p1)
        e = (p2 - p1) / ell
        rate = e @ ((v[6:9] + np.cross(v[9:12], g[9:12])) - (v[0:3] + np.cross(v[3:6], g[6:9])))
        N = s[2] * (ell - s[0]) / s[0] + s[3] * rate
        F1 = N * e
        assert np.allclose(force[b], -np.concatenate([F1, np.cross(g[6:9], F1), -F1, np.cross(g[9:12], -F1)]),
                           rtol=1e-12, atol=1e-12)
        assert np.allclose(state[b], [ell, rate, ell - s[0], s[2] * (ell - s[0]) / s[0], N], rtol=1e-12)
        U = lambda L0: s[2] * (ell - L0) ** 2 / (2 * L0)  # noqa: E731
        assert np.isclose(energy[b], U(s[0]), rtol=1e-12)
        assert np.isclose(reel[b], (U(s[0] + eps) - U(s[0] - eps)) / (2 * eps), rtol=1e-6)
        assert np.isclose(damper[b], s[3] * rate, rtol=1e-12) and np.isclose(clipped[b], -state[b, 3])
        for k in range(12):
            up = ks.cable_force(moved(g, k, eps)[None], v[None], s[None])[0][0]
            down = ks.cable_force(moved(g, k, -eps)[None], v[None], s[None])[0][0]
            scale = max(1.0, np.abs(K[b]).max())
            assert np.allclose(K[b][:, k], (up - down) / (2 * eps), atol=1e-7 * scale), (b, k)
            dv = np.eye(12)[k] * eps
            up = ks.cable_force(g[None], (v + dv)[None], s[None])[0][0]
            down = ks.cable_force(g[None], (v - dv)[None], s[None])[0][0]
            assert np.allclose(C[b][:, k], (up - down) / (2 * eps), atol=1e-7 * max(1.0, np.abs(C[b]).max()))


G, MASS, EA, REST = 9.81, 2.0, 2000.0, 1.0


def drop_reference(fall: float) -> dict:
    """A mass m dropped from rest on a slack massless cable of rest length L and stiffness k = EA/L
    that goes taut after a fall h: taut at √(2h/g) with v = √(2gh); the peak stretch δ from
    ½kδ² = ½mv² + mgδ, the peak tension kδ; slack again when the stretch returns to zero (a
    harmonic motion about mg/k, symmetric about its peak)."""
    k = EA / REST
    t_taut, v = math.sqrt(2 * fall / G), math.sqrt(2 * G * fall)
    static = MASS * G / k
    delta = static + math.sqrt(static ** 2 + MASS * v * v / k)
    omega = math.sqrt(k / MASS)
    amplitude = delta - static
    t_peak = (math.pi / 2 + math.asin(static / amplitude)) / omega
    return {"t_taut": t_taut, "delta": delta, "tension": k * delta, "t_slack": t_taut + 2 * t_peak,
            "t_peak": t_taut + t_peak}


def drop_scene(direction, offset: float, fall: float, dt: float = 1e-3, every: float = 1e-3) -> str:
    """The drop along the unit ``direction`` (gravity along it): the cable from a fixed anchor at the
    origin to a point of the weight ``offset`` from its centre towards the anchor; its ends start
    REST − fall apart."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    at = (REST - fall + offset) * d
    gravity = G * d
    vector = lambda v: "[" + ", ".join(repr(float(x)) for x in v) + "]"  # noqa: E731
    return f"""
title: a mass dropped on a slack cable
gravity: {vector(gravity)}
bodies:
  anchor: {{at: [0, 0, 0], fixed: true}}
  weight: {{at: {vector(at)}, mass: {MASS}, inertia: [0.01, 0.01, 0.01]}}
cables:
  rope: {{from: anchor, to: {{body: weight, offset: {vector(-offset * d)}}}, EA: {EA}, rest_length: {REST}}}
solve: {{analysis: transient, t_end: 0.6, dt: {dt}}}
output:
  every: {every}
  probes:
    x: {{point: weight, quantity: position, component: norm}}
    N: {{cable: rope, quantity: tension}}
    ell: {{cable: rope, quantity: length}}
    E: {{energy: total}}
    K: {{energy: kinetic}}
"""


def check_drop(summary, probes, fall, offset):
    reference = drop_reference(fall)
    events = summary["cable_events"]
    assert [e["state"] for e in events] == ["taut", "slack"]
    # the landing's tolerance, a stretch of 1e-9 L0, is 2.7e-10 s at the speed √(2gh) of these falls
    # (measured 1.3e-15 s planar, 5e-16 s in 3D: the regula falsi ends inside it)
    assert events[0]["t"] == pytest.approx(reference["t_taut"], abs=3e-10)
    # the slack change carries the integrator's phase error over the taut half-swing (ωh = 0.032:
    # measured 9.0e-6 s of 0.104 s at dt = 1e-3), the taut one only the landing's
    assert events[1]["t"] == pytest.approx(reference["t_slack"], abs=2e-5)
    assert [(e["joint"], e["kind"]) for e in summary["events"]] == [("rope", "taut"), ("rope", "slack")]
    peak = int(np.argmax(probes["N"]))
    assert probes["t"][peak] == pytest.approx(reference["t_peak"], abs=1e-3)  # the row nearest the peak
    assert probes["N"][peak] == pytest.approx(reference["tension"], rel=5e-5)
    assert probes["x"].max() - offset == pytest.approx(REST + reference["delta"], rel=5e-6)
    assert probes["ell"][peak] == pytest.approx(REST + reference["delta"], rel=5e-6)
    energy = probes["E"]  # conserved across both events: no damping, the tension rises from 0
    assert np.abs(energy - energy[0]).max() <= 2e-4 * probes["K"].max()
    assert summary["energy_balance_error"] < 1e-4


def test_mass_dropped_on_a_slack_cable_planar_through_the_cli(tmp_path):
    completed, out = latdyn_run(tmp_path, drop_scene([0, -1, 0], 0.0, 0.8), quiet=True)
    assert completed.returncode == 0, completed.stderr
    probes = probe_columns(out)
    check_drop(summary_of(out), probes, 0.8, 0.0)
    from vtkhdf_frames import read_frames  # the cable drawn as a line, its tension the probe's, read by VTK

    for frame in read_frames(out / "paraview" / "cables.vtkhdf"):
        row = int(np.argmin(np.abs(probes["t"] - frame.t)))
        assert frame.cells == [(3, [0, 1])] and probes["t"][row] == pytest.approx(frame.t, abs=1e-12)
        assert frame.cell_data["tension"][0] == pytest.approx(probes["N"][row], rel=1e-12, abs=1e-9)
        assert np.linalg.norm(frame.points[1] - frame.points[0]) == pytest.approx(probes["ell"][row], rel=1e-12)


def test_mass_dropped_on_a_slack_cable_in_3d_through_the_api(tmp_path):
    """Along a direction out of every coordinate plane, the cable at a point of the weight off its
    reference point (on the line of the fall, so that nothing turns it)."""
    scene = latdyn.load_scene(json.loads(json.dumps(__import__("yaml").safe_load(
        drop_scene([1.0, -2.0, 2.0], 0.05, 0.7)))))
    result = latdyn.run(scene, out_dir=str(tmp_path / "out"))
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    probes = {"t": np.asarray(result.t), **{k: np.asarray(result.probes[k]) for k in ("x", "N", "ell", "E", "K")}}
    check_drop(summary, probes, 0.7, 0.05)


def string_scene(axis, elements=20, tension_strain=1e-3) -> tuple[str, float, float]:
    length, EA, rhoA = 2.0, 1.0e5, 0.1
    rest = length / (1 + tension_strain)
    end = length * np.asarray(axis, float) / np.linalg.norm(axis)
    text = f"""
bodies:
  a: {{at: [0, 0, 0], fixed: true}}
  b: {{at: [{float(end[0])!r}, {float(end[1])!r}, {float(end[2])!r}], fixed: true}}
cables:
  s: {{from: a, to: b, EA: {EA}, rhoA: {rhoA}, elements: {elements}, rest_length: {rest!r}}}
solve: {{analysis: modes, about: static, count: 6}}
"""
    return text, EA * (length - rest) / rest, rhoA


@pytest.mark.parametrize("axis", [[1, 0, 0], [1, 2, -2]])
def test_taut_string_modes_about_the_pretensioned_state(tmp_path, axis):
    """Modes about the static state of a string held by its pretension T = EA (L − L0)/L0 alone: pairs
    of transverse modes at the lumped string's ω_k = 2 √(T/(m h)) sin(kπ/2n) (m = μ L0/n, h = L/n), and
    the continuous fₖ = (k/2L)√(T/μ) to the discretisation's error."""
    text, T, mu = string_scene(axis)
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    rows = np.loadtxt(out / "modes.csv", delimiter=",", skiprows=1)
    n, L = 20, 2.0
    m, h = mu * (L / (1 + 1e-3)) / n, L / n
    lumped = [2 * math.sqrt(T / (m * h)) * math.sin(k * math.pi / (2 * n)) / (2 * math.pi) for k in (1, 1, 2, 2, 3, 3)]
    assert np.allclose(rows[:, 1], lumped, rtol=2e-11, atol=0)  # measured 1.9e-14 along x, 2.4e-12 skew
    continuous = [k / (2 * L) * math.sqrt(T / mu) for k in (1, 1, 2, 2, 3, 3)]
    assert np.allclose(rows[:, 1], continuous, rtol=1e-2)


def test_latch_in_summary_events(tmp_path):
    """The events list holds latches too: a hinged arm swung onto its lock_at."""
    text = """
gravity: [0, -9.81, 0]
sections:
  s: {EA: 1.0e7, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 1.0}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: hub, to: [1, 0, 0], section: s, elements: 2, start: {hinge: {axis: [0, 0, 1], lock_at: -0.5}}}
solve: {analysis: transient, t_end: 0.6, dt: 0.005}
"""
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    events = summary_of(out)["events"]
    assert [(e["joint"], e["kind"]) for e in events] == [("arm.start", "latch")]
    assert 0.0 < events[0]["t"] < 0.6


@pytest.mark.parametrize("change, key, words", [
    ("EA: -1.0", "cables.rope.EA", "positive"),
    ("EA: 1.0, elements: 0", "cables.rope.elements", ">= 1"),
    ("EA: 1.0, elements: 3", "cables.rope.elements", "rhoA > 0"),
    ("EA: 1.0, rest_length: 0", "cables.rope.rest_length", "positive"),
    ("EA: 1.0, rest_length: 't - 1'", "cables.rope.rest_length", "> 0 at t = 0"),
    ("EA: 1.0, rhoA: -2", "cables.rope.rhoA", ">= 0"),
    ("EA: 1.0, damping: -2", "cables.rope.damping", ">= 0"),
    ("EA: 1.0, spool: 1", "cables.rope.spool", "unknown key"),
])
def test_bad_cables_are_refused_with_the_key(tmp_path, change, key, words):
    """Through the loader (the CLI's exit 2 and message: the first case, and the test below)."""
    import yaml

    from latdyn.errors import SceneError

    text = f"""
bodies:
  anchor: {{at: [0, 0, 0], fixed: true}}
  w: {{at: [1, 0, 0], mass: 1, inertia: [1, 1, 1]}}
cables:
  rope: {{from: anchor, to: w, {change}}}
solve: {{analysis: transient, t_end: 0.1, dt: 0.01}}
"""
    with pytest.raises(SceneError) as refused:
        latdyn.load_scene(yaml.safe_load(text))
    assert key in str(refused.value) and words in str(refused.value)
    if change == "EA: -1.0":
        completed, _ = latdyn_run(tmp_path, text)
        assert completed.returncode == 2 and key in completed.stderr and "Traceback" not in completed.stderr


def test_zero_length_and_unheld_free_end_are_refused(tmp_path):
    """A cable from a body to itself is refused; a slack massless cable's free end node is held by
    nothing, refused as any such coordinate is, naming the cable."""
    base = """
bodies:
  anchor: {{at: [0, 0, 0], fixed: true}}
  w: {{at: [1, 0, 0], mass: 1, inertia: [1, 1, 1]}}
cables:
  rope: {{from: anchor, to: {to}, EA: 10.0}}
solve: {{analysis: transient, t_end: 0.1, dt: 0.01}}
"""
    completed, _ = latdyn_run(tmp_path, base.format(to="anchor"))
    assert completed.returncode == 2 and "cables.rope" in completed.stderr and "zero-length" in completed.stderr
    completed, _ = latdyn_run(tmp_path, base.format(to="[2, 0, 0]"))
    assert completed.returncode == 2 and "cables.rope" in completed.stderr and "nothing holds" in completed.stderr


def catenary_scene(span_vector) -> str:
    b = ", ".join(repr(float(x)) for x in span_vector)
    return f"""
title: elastic catenary
gravity: [0, -9.81, 0]
bodies:
  a: {{at: [0, 0, 0], fixed: true}}
  b: {{at: [{b}], fixed: true}}
cables:
  rope: {{from: a, to: b, EA: 1.0e4, rhoA: 1.0, elements: 20, rest_length: 9.99}}
solve: {{analysis: static, steps: 10}}
output:
  probes:
    sag: {{point: rope.node[10], quantity: position, component: y}}
    N: {{cable: rope, quantity: tension}}
"""


def brent(f, lo, hi):
    """The root of f in [lo, hi] by bisection to round-off (no SciPy needed)."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(lo) * f(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("span_vector", [[10.0, 0.0, 0.0], [6.0, 0.0, 8.0]])
def test_elastic_catenary_static(tmp_path, span_vector):
    """A cable of 20 elements hung between two supports 10 apart at one height, pretensioned at the start
    (rest length 9.99: loads are ramped, rest lengths are not), under its own weight: the midspan sag and
    the first element's tension against the exact statics of the lumped chain (H from the span), and
    against Irvine's elastic catenary to the discretisation's error (sag; the support tension half an
    element away)."""
    completed, out = latdyn_run(tmp_path, catenary_scene(span_vector), quiet=True)
    assert completed.returncode == 0, completed.stderr
    probes = probe_columns(out)
    assert probes["N"][0] == pytest.approx(1.0e4 * (10 - 9.99) / 9.99, rel=1e-12)  # the pretension at λ = 0
    span, L0, EA, w, n = 10.0, 9.99, 1.0e4, 9.81, 20
    P = w * L0 / n

    def chain(H):
        V = (n - 1) * P / 2 - np.arange(n) * P
        T = np.hypot(H, V)
        return L0 / n * (1 + T / EA), V, T

    H = brent(lambda H: np.sum(chain(H)[0] * H / chain(H)[2]) - span, 1.0, 1e5)
    ell, V, T = chain(H)
    # the lumped chain's statics to round-off (measured 4.4e-15 and 2.7e-15, both spans)
    assert -probes["sag"][-1] == pytest.approx(np.sum((ell * V / T)[: n // 2]), rel=1e-13)
    assert probes["N"][-1] == pytest.approx(T[0], rel=1e-13)
    Vc = w * L0 / 2
    Hc = brent(lambda H: H * L0 / EA + 2 * H / w * np.arcsinh(Vc / H) - span, 1.0, 1e5)
    irvine_sag = L0 / (2 * EA) * (Vc - w * L0 / 4) + Hc / w * (np.sqrt(1 + (Vc / Hc) ** 2) - 1)
    assert -probes["sag"][-1] == pytest.approx(irvine_sag, rel=1.5e-3)  # measured 8.2e-4
    assert probes["N"][-1] == pytest.approx(math.hypot(Hc, Vc), rel=1e-2)  # measured 4.9e-3


SLACK_HANGING_CABLE = """\
title: a slack cable between two anchors
gravity: [0, 0, -9.81]
bodies:
  a: {at: [0, 0, 0], fixed: true}
  b: {at: [6, 0, 8], fixed: true}
cables:
  c: {from: a, to: b, EA: 1000.0, rhoA: 0.5, elements: 8, rest_length: REST}
solve: {analysis: static, steps: 10}
"""


def test_a_slack_cable_in_a_static_analysis_is_refused_as_slack_not_as_a_mechanism(tmp_path):
    """A cable hung slack (rest length 12 between anchors 10 apart, on a skew span) has a hanging
    equilibrium, but its straight start carries no tension, so the static Newton has no stiffness
    in its inner nodes. The refusal (exit 1, as before) said "the structure is a mechanism there,
    whose motion a transient run follows"; it now names the cable as slack and the remedies (a
    pretension, a transient run). A cable with no pretension (rest length = the distance) is
    slack too (N = 0 at ℓ = L₀); a pretensioned one solves."""
    for rest in ("12.0", "10.0"):
        completed, _ = latdyn_run(tmp_path, SLACK_HANGING_CABLE.replace("REST", rest), quiet=True)
        assert completed.returncode == 1, completed.stderr
        assert "cable c is slack at load factor 0" in completed.stderr
        assert "pretension" in completed.stderr and "mechanism" not in completed.stderr
    with pytest.raises(latdyn.errors.SolverError, match="cable c is slack at load factor 0.*a rest_length shorter"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(SLACK_HANGING_CABLE.replace("REST", "12.0"))))
    taut = latdyn.run(latdyn.load_scene(yaml.safe_load(SLACK_HANGING_CABLE.replace("REST", "9.99"))))
    assert taut.summary["status"] == "solved"


def test_reel_work_is_external_work(tmp_path):
    """A winch shortening the rest length (1 − 0.3 t²) lifts a hanging mass through a damped cable: the
    reel's power ∂U/∂L0 · L̇0 is external work, so the energy balance holds to the integrator's error;
    the mass follows the rest length (quasi-static, N ≈ m (g + 0.6))."""
    text = """
gravity: [0, -9.81, 0]
bodies:
  anchor: {at: [0, 0, 0], fixed: true}
  weight: {at: [0, -1.00981, 0], mass: 2.0, inertia: [0.01, 0.01, 0.01]}
cables:
  rope: {from: anchor, to: weight, EA: 2000.0, damping: 5.0, rest_length: "1 - 0.3*t**2"}
solve: {analysis: transient, t_end: 1.0, dt: 0.001}
output:
  every: 0.01
  probes:
    y: {point: weight, quantity: position, component: y}
    E: {energy: total}
    W: {energy: external_work}
    D: {energy: dissipated}
"""
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary, probes = summary_of(out), probe_columns(out)
    assert summary["energy_balance_error"] < 1e-6  # measured 8.9e-8
    gained = probes["E"][-1] - probes["E"][0]
    assert gained == pytest.approx(probes["W"][-1] - probes["D"][-1], rel=7e-8)  # measured 6.6e-9
    assert gained > 6.0 and probes["D"][-1] > 0.1
    assert probes["y"][-1] == pytest.approx(-0.7 * (1 + 2.0 * (9.81 + 0.6) / 2000.0), abs=3e-3)
    assert summary["events"] == [] and summary["cable_events"] == []


def test_checkpoint_and_resume_across_a_cable_event_bit_for_bit(tmp_path, monkeypatch):
    """Interrupted between the taut and the slack change, resumed: probes, state history, ParaView
    frames (the cables part included) and summary.json (events included) equal the uninterrupted run's."""
    from test_checkpoint import interrupt_at, relative_difference
    from vtkhdf_frames import assert_same_frames

    import yaml

    scene = yaml.safe_load(drop_scene([0, -1, 0], 0.0, 0.8, dt=2e-3, every=1e-2))
    reference, out = tmp_path / "full", tmp_path / "out"
    latdyn.run(scene, str(reference))
    with monkeypatch.context() as m:
        interrupt_at(m, 0.45)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, str(out))
    latdyn.run(scene, str(out), resume=True)
    assert relative_difference(reference, out) == 0.0
    for name in ("beams", "bodies", "cables"):
        if (reference / "paraview" / f"{name}.vtkhdf").exists():
            assert_same_frames(reference / "paraview" / f"{name}.vtkhdf", out / "paraview" / f"{name}.vtkhdf")
    a, b = (json.loads((p / "summary.json").read_text()) for p in (reference, out))
    extra = {"wall_time_s", "solver_s", "compile_s", "resumed_from_t", "resumes"}
    assert {k: v for k, v in b.items() if k not in extra} == {k: v for k, v in a.items() if k not in extra}
    assert [e["state"] for e in b["cable_events"]] == ["taut", "slack"]


def test_a_study_varies_a_cables_rest_length(tmp_path):
    """A study over cables.rope.rest_length: each case goes taut after its own fall, at √(2h/g)."""
    import yaml

    (tmp_path / "drop.yaml").write_text(drop_scene([0, -1, 0], 0.0, 0.8, dt=2e-3, every=1e-2))
    study = {"scene": "drop.yaml", "vary": {"cables.rope.rest_length": [1.0, 1.2]},
             "reference": {"overrides": {"solve.dt": 1e-3}}, "error": {"probe": "N", "norm": "max"}}
    (tmp_path / "study.yaml").write_text(yaml.safe_dump(study))
    latdyn.study(str(tmp_path / "study.yaml"), out=str(tmp_path / "out"), progress=False)
    with open(tmp_path / "out" / "study.csv") as f:
        rows = list(__import__("csv").DictReader(f))
    assert [r["status"] for r in rows] == ["solved", "solved"]
    for row in rows:
        rest = float(row["cables.rope.rest_length"])
        summary = json.loads((tmp_path / "out" / "cases" / row["case"] / "summary.json").read_text())
        assert summary["cable_events"][0]["t"] == pytest.approx(math.sqrt(2 * (rest - 0.2) / G), abs=1e-8)


def test_stop_impacts_in_summary_events(tmp_path):
    """The events list holds impacts on hinge stops (kind stop), in time order; a hinge resting on its
    stop is no new event."""
    text = """
gravity: [0, -9.81, 0]
sections:
  s: {EA: 1.0e7, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 1.0}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: hub, to: [1, 0, 0], section: s, elements: 2,
        start: {hinge: {axis: [0, 0, 1], limits: [-0.5, 1.0], restitution: 0.5}}}
solve: {analysis: transient, t_end: 1.5, dt: 0.005}
"""
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    events = summary_of(out)["events"]
    assert len(events) >= 2 and {(e["joint"], e["kind"]) for e in events} == {("arm.start", "stop")}
    times = [e["t"] for e in events]
    assert times == sorted(times) and len(set(times)) == len(times)


def test_damped_cable_goes_slack_where_its_tension_reaches_zero(tmp_path):
    """The drop with an axial damper c: taut at √(2h/g) (the tension jumps to c v there), slack where
    N = k x + c ẋ reaches zero (before the stretch does), both against the closed form of the damped
    oscillator; the damper's work is declared dissipation, so the energy balance holds."""
    c, fall = 20.0, 0.8
    text = drop_scene([0, -1, 0], 0.0, fall, dt=5e-4, every=5e-4).replace(
        "rest_length: 1.0}", f"rest_length: 1.0, damping: {c}}}").replace(
        "    K: {energy: kinetic}", "    K: {energy: kinetic}\n    D: {energy: dissipated}")
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary, probes = summary_of(out), probe_columns(out)
    k = EA / REST
    t_taut, v = math.sqrt(2 * fall / G), math.sqrt(2 * G * fall)
    omega, zeta = math.sqrt(k / MASS), c / (2 * math.sqrt(k * MASS))
    wd, static = omega * math.sqrt(1 - zeta ** 2), MASS * G / k
    A, B = -static, (v - zeta * omega * static) / wd  # y = x − x_eq, y(0) = −x_eq, ẏ(0) = v

    def tension(tau):
        e = math.exp(-zeta * omega * tau)
        y = e * (A * math.cos(wd * tau) + B * math.sin(wd * tau))
        ydot = e * ((B * wd - zeta * omega * A) * math.cos(wd * tau) - (A * wd + zeta * omega * B) * math.sin(wd * tau))
        return k * (y + static) + c * ydot

    lo, hi = math.pi / (2 * wd), math.pi / wd  # N > 0 at the peak, < 0 by half a period
    slack = t_taut + brent(tension, lo, hi)
    events = summary["cable_events"]
    assert [e["state"] for e in events] == ["taut", "slack"]
    assert events[0]["t"] == pytest.approx(t_taut, abs=3e-10)  # the landing's tolerance; measured 2.4e-15 s
    assert events[1]["t"] == pytest.approx(slack, abs=1e-5)  # measured 1.6e-6 s
    peak = max(tension(tau) for tau in np.linspace(0.0, hi, 20001))
    assert probes["N"].max() == pytest.approx(peak, rel=5e-5)  # measured +2.5e-5
    assert summary["energy_balance_error"] < 1e-4  # measured 8.1e-6 (3.8e-5 with the time trapezoid of the power)
    assert probes["D"][-1] > 0.1 * probes["K"].max()


def test_massless_free_end_going_slack_ends_the_run_naming_the_cable(tmp_path):
    """A massless cable from an anchor to a free end point, kept taut by a load on its end along it
    that falls to zero at t = 0.25 and then pushes: the end is held by the tension alone (no mass,
    nothing else attached), so when the cable goes slack nothing holds it. The run ends there
    (exit 1) with the slack change recorded and a message that names the cable and what to add,
    not Newton's diagnosis naming the end's coordinates. The rest length 100/101 makes the pull at
    t = 0, EA (1 − L0)/L0 = 1 N, the load's: the end starts in equilibrium (a massless end that does
    not is refused, tests/test_review_defects.py)."""
    text = """
bodies:
  anchor: {at: [0, 0, 0], fixed: true}
cables:
  rope: {from: anchor, to: [1, 0, 0], EA: 100.0, rest_length: "100/101"}
loads:
  - {at: rope.end, force: ["1 - 4*t", 0, 0]}
solve: {analysis: transient, t_end: 0.5, dt: 0.01}
"""
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 1 and "Traceback" not in completed.stderr
    error = completed.stderr[completed.stderr.index("latdyn: error"):]
    assert "cables.rope went slack" in error and "rope.end" in error and "rhoA" in error
    assert "rope.end:d" not in error  # not Newton's coordinate-level diagnosis
    summary = summary_of(out)
    assert summary["status"] == "failed"
    assert [e["state"] for e in summary["cable_events"]] == ["slack"]
    assert summary["cable_events"][0]["t"] == pytest.approx(0.25, abs=1e-9)  # the load's zero, a grid time


def test_a_slack_refusal_inside_the_loop_of_steps_keeps_its_rows_in_time(tmp_path):
    """A massless cable pretensioned to a free end (rest length 3.27 against 3.2773 m: 166.7 N) and
    reeled in, its pull balanced at t = 0 by a load at the end that falls to zero at t = 0.04, stepped
    by the loop of steps in C with its rows: it is found slack at t = 0.04, which ends the run (exit 1)
    with the rows 0, 0.02, 0.04 — not a fourth row of the state at the loop's start (t = 0, recorded
    after the loop's rows when the refusal came before the loop's end state was taken: found by
    benchmarks/fuzz_runs.py --joints, with a pretension nothing balanced, which is refused now: the
    end snapped in the first step, its tension 2e5 N → 3e-11 N)."""
    b, end = np.array([0.0, -1.8, 0.0]), np.array([-0.86, 1.35, -0.28])
    length = np.linalg.norm(end - b)
    pull = 7.5e4 * (length - 3.27) / 3.27 * (end - b) / length
    force = ", ".join(f'"{float(f)!r}*(1 - 25*t)"' for f in pull)
    text = """
sections:
  s: {EA: 3.0e6, EIy: 1600.0, EIz: 1400.0, GJ: 1100.0, rhoA: 1.8}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b: {at: [0, -1.8, 0], mass: 1.3}
beams:
  arm: {from: g, to: b, section: s, elements: 2}
cables:
  c: {from: b, to: [-0.86, 1.35, -0.28], EA: 7.5e4, damping: 12.0, rest_length: "3.27 - 0.25*t"}
loads:
  - {at: c.end, force: [FORCE]}
solve: {analysis: transient, t_end: 0.1, dt: 0.02}
output:
  probes:
    tension: {cable: c, quantity: tension}
""".replace("FORCE", force)
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 1 and "cables.c went slack at t = 0.04" in completed.stderr
    t = probe_columns(out)["t"]
    assert np.allclose(t, [0.0, 0.02, 0.04], rtol=0, atol=1e-15)


def test_massive_free_end_goes_slack_and_on(tmp_path):
    """The same with mass on the cable (rhoA > 0: half its mass lumped at the free end): the end is held
    by its inertia while slack, and the run goes on past the slack change."""
    text = """
bodies:
  anchor: {at: [0, 0, 0], fixed: true}
cables:
  rope: {from: anchor, to: [1, 0, 0], EA: 100.0, rhoA: 0.02, rest_length: 0.99}
loads:
  - {at: rope.end, force: ["1 - 4*t", 0, 0]}
solve: {analysis: transient, t_end: 0.5, dt: 0.01}
"""
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    assert [e["state"] for e in summary_of(out)["cable_events"]][:1] == ["slack"]


def damped_drop_reference(mass, EA, c, rest, y0, t_end, g=G, pay_out=0.0):
    """A point mass dropped from rest at height y0 < 0 under an anchor at the origin on a Kelvin–Voigt
    cable of rest length L0(t) = ``rest`` + ``pay_out`` t (a reel), integrated by scipy's solve_ivp
    (DOP853, rtol 1e-12) piece by piece between events: slack (free fall) until the stretch
    x = −y − L0 rises through zero, taut (m ÿ = −m g + N, N = EA x/L0 + c ℓ̇ with ℓ̇ = −ẏ, SCENE.md's
    c·dℓ/dt) until N or the stretch falls through zero (the stretch first only where the reel pays the
    cable out faster than it lengthens). Returns the events [(t, "taut" | "slack")] and y(t)."""
    from scipy.integrate import solve_ivp

    def length(t):
        return rest + pay_out * t

    def slack(t, s):
        return [s[1], -g]

    def taut(t, s):
        return [s[1], -g + tension(t, s) / mass]

    def stretch(t, s):
        return -s[0] - length(t)

    def tension(t, s):
        return EA * (-s[0] - length(t)) / length(t) - c * s[1]

    def shortening(t, s):
        return stretch(t, s)

    stretch.terminal, stretch.direction = True, 1
    tension.terminal, tension.direction = True, -1
    shortening.terminal, shortening.direction = True, -1
    t, s, side, events, pieces = 0.0, np.array([y0, 0.0]), -1, [], []
    while t < t_end:
        law, event = (slack, [stretch]) if side < 0 else (taut, [tension, shortening])
        sol = solve_ivp(law, (t, t_end), s, events=event, dense_output=True, rtol=1e-12, atol=1e-14,
                        method="DOP853")
        pieces.append((t, sol.t[-1], sol.sol))
        t, s = sol.t[-1], sol.y[:, -1]
        if sol.status == 1:
            side = -side
            events.append((t, "taut" if side > 0 else "slack"))

    def y(time):
        return next(p(time)[0] for a, b, p in pieces if a <= time <= b)

    return events, y


def light_drop_scene(c: float, dt: float) -> str:
    return f"""
gravity: [0, -9.81, 0]
bodies:
  anchor: {{at: [0, 0, 0], fixed: true}}
  weight: {{at: [0, -0.9, 0], mass: 0.1, inertia: [0.001, 0.001, 0.001]}}
cables:
  rope: {{from: anchor, to: weight, EA: 2000.0, damping: {c}, rest_length: 1.0}}
solve: {{analysis: transient, t_end: 0.5, dt: {dt}}}
output:
  every: 0.001
  probes:
    y: {{point: weight, quantity: position, component: y}}
    N: {{cable: rope, quantity: tension}}
"""


@pytest.mark.parametrize("c, taut_and_slack", [(2.0, 4), (50.0, 1)])
def test_damped_drop_of_a_light_mass_against_an_independent_integration(tmp_path, c, taut_and_slack):
    """0.1 kg dropped 0.1 m onto a Kelvin–Voigt cable (EA = 2 kN, L = 1 m) whose tension never pushes:
    N = max(0, k x + c ẋ) while stretched. Lightly damped (c = 2 N·s/m) it bounces: taut, slack where N
    reaches zero (still stretched), free flight, taut again; overdamped (c = 50, the damper time
    m/c = 2 ms) it settles taut after one change. Against scipy's solve_ivp of the same law with events
    (dt = 1e-4): every change's time (measured 4.8e-6 s, c = 2; 8.6e-16 s, c = 50) and the mass's
    position at every row (measured 4.9e-6 m, c = 2; 7.7e-7 m, c = 50)."""
    import yaml

    scene = latdyn.load_scene(yaml.safe_load(light_drop_scene(c, 1e-4)))
    result = latdyn.run(scene, out_dir=str(tmp_path / "out"))
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    events, y = damped_drop_reference(0.1, 2000.0, c, 1.0, -0.9, 0.5)
    got = [(e["t"], e["state"]) for e in summary["cable_events"]]
    assert len(events) == taut_and_slack and [s for _, s in got] == [s for _, s in events]
    assert max(abs(a - b) for (a, _), (b, _) in zip(got, events)) < 1e-5
    t, position, tension = np.asarray(result.t), np.asarray(result.probes["y"]), np.asarray(result.probes["N"])
    assert max(abs(position[i] - y(t[i])) for i in range(len(t))) < 1e-5
    assert tension.min() >= 0.0


def test_stiffly_damped_light_drop_at_the_damper_time_step(tmp_path):
    """The overdamped drop (c = 50 N·s/m on 0.1 kg) at a step as long as its damper time m/c = 2 ms: it
    runs to the end and settles taut (one change), and its energy balance holds with the damper's
    dissipation integrated over each step's Δℓ (measured 7.9e-4; 2.1e-2 with the time trapezoid of its
    power that this replaced)."""
    completed, out = latdyn_run(tmp_path, light_drop_scene(50.0, 2e-3), quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary, probes = summary_of(out), probe_columns(out)
    assert [e["state"] for e in summary["cable_events"]] == ["taut"]
    assert summary["energy_balance_error"] < 2e-3
    static = -1.0 - 0.1 * G / 2000.0
    assert probes["y"][-1] == pytest.approx(static, abs=1e-6)


def test_a_damped_cable_paid_out_faster_than_its_load_follows_chatters_as_its_law_says(tmp_path):
    """Why a damped cable on a reel changes state hundreds of times (docs/cables.md, "A damped cable on
    light parts"): its damper acts on dℓ/dt (SCENE.md), so a cable paid out at u carries c u at zero
    stretch. Where c u exceeds the load that pulls the cable out (here 0.1 kg under gravity, 0.98 N,
    against c u = 25 N), the law has no taut steady motion: taut at zero stretch the tension jumps to
    c ℓ̇ and stops the mass within about m/c; the reel runs ahead and the cable goes slack at zero
    stretch while its damper still pulls (a jump from c ℓ̇ to 0); the load falls until the stretch is
    zero again, faster than the reel, and the cycle repeats, shorter each time. Against scipy's
    solve_ivp of the same law with events (0.5 s): the same 14 changes at dt = 1e-4 and 5e-5 (the count
    does not grow as the step is halved); the first four within 1e-4 s (measured 4.6e-5 s at 1e-4); the
    last change's error halves with the step (first order: nothing restarts the step after the slack
    jump; measured 5.3e-3 → 2.6e-3 s, each cycle's error growing into the next); the position to
    1e-3 m (measured 4.8e-4 m at 1e-4)."""
    text = light_drop_scene(50.0, 1e-4).replace("rest_length: 1.0", 'rest_length: "1.0 + 0.5*t"')
    events, y = damped_drop_reference(0.1, 2000.0, 50.0, 1.0, -0.9, 0.5, pay_out=0.5)
    assert len(events) == 14  # seven cycles: free fall back to zero stretch, a stop in about m/c
    errors = {}
    for dt in (1e-4, 5e-5):
        path = tmp_path / f"reel_{dt}.yaml"
        path.write_text(text.replace("dt: 0.0001", f"dt: {dt}"))
        result = latdyn.run(latdyn.load_scene(str(path)))
        got = [(e["t"], e["state"]) for e in result.summary["cable_events"]]
        assert [s for _, s in got] == [s for _, s in events]
        errors[dt] = np.array([abs(a - b) for (a, _), (b, _) in zip(got, events)])
        assert np.asarray(result.probes["N"]).min() >= 0.0
        if dt == 1e-4:
            assert errors[dt][:4].max() < 1e-4
            t, position = np.asarray(result.t), np.asarray(result.probes["y"])
            assert max(abs(position[i] - y(t[i])) for i in range(len(t))) < 1e-3
    assert errors[5e-5][-1] < 0.6 * errors[1e-4][-1]


def test_the_cables_work_from_python_equals_the_loop_of_steps_in_c_bit_for_bit(monkeypatch):
    """The cable-controlled deploying truss (examples/cable_deploying_truss.yaml) to t = 0.6, its reel's work and
    the energies probed: with the loop of steps in C (which hands the steps at the cables' slack and taut events to
    Python) and with every step from Python, the same states and the same external work and dissipation bit for bit:
    both count the cables' and the hinges' work with csrc/newton_step.c cable_work and hinge_work. Before, the steps
    from Python summed the cables' work with NumPy of their own, and the two external works differed by up to
    1.3e-15 (of 1.2 J)."""
    import latdyn.timeloop.transient as transient_module
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "examples" / "cable_deploying_truss.yaml").read_text()
    text = text.replace("t_end: 4.0", "t_end: 0.6").replace(
        "    pull: {cable: tie_a, quantity: tension}",
        "    pull: {cable: tie_a, quantity: tension}\n    W: {energy: external_work}\n    D: {energy: dissipated}")
    looped = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    monkeypatch.setattr(transient_module, "COMPILED_LOOP", False)
    stepped = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert looped.summary["time_loop"] == "compiled" and stepped.summary["time_loop"] == "python"
    assert looped.summary["cable_events"] and looped.summary["steps"] == stepped.summary["steps"]
    for name in ("tip_x", "tip_z", "pull", "W", "D"):
        assert np.array_equal(np.asarray(looped.probes[name]), np.asarray(stepped.probes[name])), name
    assert looped.summary["energy_balance_error"] == stepped.summary["energy_balance_error"]


def test_a_cable_element_crosses_its_change_by_the_loop_of_steps_test_at_its_tolerance(tmp_path):
    """Which cable elements a step crossed is the loop of steps' own test (csrc/newton_step.c cable_crossed, through
    NativeModel.cable_crossed: latdyn/timeloop/events.py cable_crossings calls it): an element held taut crossed
    where its gap ends below −tolerance, one held slack where it ends above +tolerance, one on neither side (0,
    every other analysis) never; a gap on the tolerance is not past it. The tolerance is cable_tolerance of its EA,
    1e-9 EA."""
    from latdyn.assembly.prepare import prepare
    from latdyn.model.cables import cable_tolerance

    scene = tmp_path / "drop.yaml"
    scene.write_text(drop_scene([0, 0, -1], 0.0, 0.3))
    assembler = prepare(latdyn.load_scene(scene), "c").assembler
    native, cables = assembler.native(), assembler.model.cables
    tol = float(cable_tolerance(cables.EA)[0])
    assert tol == 1e-9 * EA
    gaps = [-2 * tol, -tol, -0.5 * tol, 0.0, 0.5 * tol, tol, 2 * tol]
    expected = {1.0: [True, False, False, False, False, False, False],
                -1.0: [False, False, False, False, False, False, True],
                0.0: [False] * 7}
    for side, crossed in expected.items():
        cables.sides[:] = side
        assert [bool(native.cable_crossed(np.array([gap]))[0]) for gap in gaps] == crossed, side
    with pytest.raises(ValueError, match="cable elements"):
        native.cable_crossed(np.zeros(2))
