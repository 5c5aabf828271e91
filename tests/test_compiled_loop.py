"""The loop of steps in C (engine.CompiledGeneralizedAlpha.advance, csrc/newton_step.c
latdyn_advance) and the scene's laws compiled by the code generator (codegen/laws.py).

References: the same run with every step taken from Python (``latdyn.timeloop.transient.COMPILED_LOOP = False``,
one call into C per step, the laws evaluated by ``latdyn.scene.expressions``), which the loop must
equal to round-off with the same steps, iterations, factorizations and rejected steps, through
rows that span several steps, Newton failures and cuts, latches and hinge stops; and the
reference step of tests/reference_step.py for hinge laws in θ, θ̇ and t, which run compiled.
The compiled laws equal :class:`~latdyn.scene.expressions.TimeFunction` and
:class:`~latdyn.scene.expressions.HingeLaw` at random arguments.
"""
from __future__ import annotations

import copy
import ctypes

import numpy as np
import pytest

import latdyn
import latdyn.timeloop.transient as transient_module
from latdyn.scene.expressions import HingeLaw, TimeFunction
from latdyn.model.kernels import load_kernels

from cli_runs import latdyn_run_switched, summary_of
from test_engine import _relative_difference, _run, loaded_arm
from test_hinges import stop_scene
from test_inertia import _compare, hinged_chain, rigid_motion

try:
    load_kernels("c", "default")
    HAVE_C = True
except RuntimeError:
    HAVE_C = False

pytestmark = pytest.mark.skipif(not HAVE_C, reason="no C compiler: the compiled step needs one")

COUNTERS = ("steps", "newton_iterations", "rejected_steps", "newton_cuts", "factorizations")


def _both(raw, tmp_path, monkeypatch, **solve):
    """The run with the loop in C and the run stepped from Python, with their summaries."""
    runs = {}
    for loop in (True, False):
        monkeypatch.setattr(transient_module, "COMPILED_LOOP", loop)
        runs[loop] = _run(raw, tmp_path, f"loop_{loop}", **solve)
    return runs[True], runs[False]


def _assert_same_run(looped, stepped, tolerance=1e-12):
    (a, a_summary), (b, b_summary) = looped, stepped
    assert a_summary["time_loop"] == "compiled" and b_summary["time_loop"] == "python"
    for key in COUNTERS:
        assert a_summary[key] == b_summary[key], key
    assert np.array_equal(np.asarray(a.t), np.asarray(b.t))
    assert _relative_difference(a, b) <= tolerance
    assert a_summary["energy_balance_error"] == pytest.approx(b_summary["energy_balance_error"], rel=1e-9, abs=1e-14)


@pytest.mark.parametrize("every", [None, 0.02])
def test_loop_equals_stepping_from_python(every, tmp_path, monkeypatch):
    """A 3D arm with every kind of law (prescribed hinge angle, torque, global and follower
    loads of t), free bodies, gravity; rows every step and every 4 steps."""
    raw = loaded_arm(t_end=0.3)
    if every is not None:
        raw["output"]["every"] = every
    looped, stepped = _both(raw, tmp_path, monkeypatch, engine="compiled", newton="full")
    _assert_same_run(looped, stepped)
    assert len(looped[0].t) == (61 if every is None else 16)


def test_loop_hands_a_latch_back_to_the_time_loop(tmp_path, monkeypatch):
    """Hinge c latches at t ≈ 0.146 s: the loop returns the step that reaches lock_at, the time
    loop shortens it onto the event and latches; then the loop goes on with the new numbering."""
    raw = loaded_arm(t_end=0.3, lock_at=-0.12)
    raw["output"]["every"] = 0.05
    looped, stepped = _both(raw, tmp_path, monkeypatch, engine="compiled")
    _assert_same_run(looped, stepped)
    rate = np.asarray(looped[0].probes["c_hinge"])
    assert np.any(rate != 0.0) and rate[-1] == 0.0  # moved, then latched


def test_loop_hands_impacts_on_a_stop_back(tmp_path, monkeypatch):
    raw = stop_scene(0.5)
    looped, stepped = _both(raw, tmp_path, monkeypatch)
    _assert_same_run(looped, stepped)
    assert np.min(looped[0].probes["rate"]) < 0 < np.max(looped[0].probes["rate"])  # bounced


EVENTS_3D = """\
title: a 3D arm into its stops, a latch and a cable that goes slack and taut
gravity: [0.5, -1.0, -9.81]
sections:
  arm: {EA: 1.0e6, EIy: 200.0, EIz: 300.0, GJ: 150.0, rhoA: 0.5, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  post: {at: [0, 0, 0.8], fixed: true}
  hub: {at: [0.6, 0.1, 0.0], mass: 0.5, inertia: [0.002, 0.003, 0.004]}
  tip: {at: [1.1, 0.4, -0.1], mass: 0.3, inertia: [0.001, 0.001, 0.001]}
beams:
  a:
    from: base
    to: hub
    section: arm
    elements: 2
    start: {hinge: {axis: [0, 0.2, 1], limits: [-0.25, 0.3], restitution: 0.6, torque: "2*sin(5*t)"}}
  b:
    from: hub
    to: tip
    section: arm
    elements: 2
    start: {hinge: {axis: [0.3, 1, 0.2], lock_at: -0.45, torque: "0.6", damping: 0.01}}
cables:
  rope: {from: post, to: tip, EA: 2000.0, rest_length: 1.45, elements: 1}
initial_velocity: {angular: [0.5, -0.3, 1.5], about: [0, 0, 0]}
solve: {analysis: transient, t_end: 0.5, dt: 0.002}
output:
  every: 0.01
  probes:
    a: {hinge: a.start, quantity: angle}
    b: {hinge: b.start, quantity: angle}
    N: {cable: rope, quantity: tension}
    tipz: {point: tip, quantity: position, component: z}
    W: {energy: external_work}
    D: {energy: dissipated}
"""


def test_an_event_heavy_3d_scene_gives_the_same_bits_from_python_and_in_the_loop(tmp_path):
    """A 3D arm that goes into its stops (twice in 0.1 s), latches, and pulls a cable that goes slack, taut and
    slack again, through the CLI with the loop of steps in C and with every step from Python: probes.csv the
    same bytes, state.h5 the same datasets bit for bit, the same events at the same instants. The loop tests
    the events with csrc/newton_step.c hinge_event and cable_event, the steps from Python with
    latdyn/timeloop/events.py, from the one definition of each tolerance (the native model's
    hinge_event_tolerance and cable_tolerance)."""
    h5py = pytest.importorskip("h5py")
    scene = tmp_path / "arm.yaml"
    scene.write_text(EVENTS_3D)
    outs = {}
    for loop in (True, False):
        outs[loop] = tmp_path / f"loop_{loop}"
        completed = latdyn_run_switched(tmp_path, scene, outs[loop], "import latdyn.timeloop.transient as m; "
                                        f"m.COMPILED_LOOP = {loop}")
        assert completed.returncode == 0, completed.stderr
    looped, stepped = (summary_of(outs[loop]) for loop in (True, False))
    assert looped["time_loop"] == "compiled" and stepped["time_loop"] == "python"
    kinds = {(e["joint"], e["kind"]) for e in looped["events"]}
    assert {("rope", "slack"), ("rope", "taut"), ("a.start", "stop"), ("b.start", "latch")} <= kinds
    for key in ("events", "cable_events", "steps", "newton_iterations", "energy_balance_error"):
        assert looped[key] == stepped[key], key
    assert (outs[True] / "probes.csv").read_bytes() == (outs[False] / "probes.csv").read_bytes()
    with h5py.File(outs[True] / "state.h5") as a, h5py.File(outs[False] / "state.h5") as b:
        names = []
        a.visititems(lambda name, item: names.append(name) if isinstance(item, h5py.Dataset) else None)
        assert names
        for name in names:
            assert a[name][()].tobytes() == b[name][()].tobytes(), name


def test_the_loop_reads_the_event_tolerances_python_defines(tmp_path):
    """The loop of steps in C tests the hinges' and the cables' events with the tolerances latdyn/model defines
    (lock_tolerance of each lock_at and stop, cable_tolerance of each cable element), handed to it through the
    native model: there is no second definition in C."""
    from latdyn.assembly.prepare import prepare
    from latdyn.model.cables import cable_tolerance
    from latdyn.model.model import lock_tolerance

    scene = tmp_path / "arm.yaml"
    scene.write_text(EVENTS_3D)
    assembler = prepare(latdyn.load_scene(scene), "c").assembler
    native, model = assembler.native(), assembler.model
    held = np.ctypeslib.as_array(ctypes.cast(native.model.hinge_event_tolerance, ctypes.POINTER(ctypes.c_double)),
                                 (len(model.hinges), 3))
    expected = [[0.0 if at is None else lock_tolerance(at) for at in
                 (h.lock_at,) + (tuple(h.limits) if h.limits is not None else (None, None))] for h in model.hinges]
    assert held.tolist() == expected and np.count_nonzero(held) == 3
    cables = np.ctypeslib.as_array(ctypes.cast(native.model.cable_tolerance, ctypes.POINTER(ctypes.c_double)),
                                   (len(model.cables.EA),))
    assert cables.tolist() == cable_tolerance(model.cables.EA).tolist() == [1e-9 * 2000.0]


def test_the_hinge_events_from_python_are_the_loop_of_steps_test_at_the_tolerances(tmp_path):
    """Which hinges reach or cross their lock_at, cross a stop or meet it is the loop of steps' own test
    (csrc/newton_step.c hinge_crossings, through NativeModel.hinge_crossings; latdyn/timeloop/events.py
    lock_events, stop_crossings and stop_hits read its flags), at the tolerance 1e-7 max(1, |at|): steps that end
    just inside and just past each, with exact references."""
    from latdyn.assembly.prepare import prepare
    from latdyn.timeloop import events

    scene = tmp_path / "arm.yaml"
    scene.write_text(EVENTS_3D)
    prepared = prepare(latdyn.load_scene(scene), "c")
    assembler, model = prepared.assembler, prepared.model
    a, b = model.hinge_index("a", "start"), model.hinge_index("b", "start")  # stops [-0.25, 0.3]; lock_at -0.45
    tol = 1e-7
    cases = [  # (θ_a, θ̇_a, θ_b) at the step's start, at its end; the flags of a, of b
        ((0.0, 1.0, -0.4), (0.3 + 2 * tol, 1.0, -0.45 + 0.9 * tol), events.UPPER_CROSSED | events.UPPER_HIT,
         events.LOCK_REACHED),
        ((0.0, 1.0, -0.4), (0.3 - 0.9 * tol, 1.0, -0.45 - 2 * tol), events.UPPER_HIT, events.LOCK_CROSSED),
        ((0.0, 1.0, -0.4), (0.3 - 0.9 * tol, -1.0, -0.45 + 2 * tol), 0, 0),
        ((0.0, -1.0, -0.45), (-0.25 - 2 * tol, -1.0, -0.3), events.LOWER_CROSSED | events.LOWER_HIT, events.LOCK_REACHED),
        ((-0.25 + 0.9 * tol, -1.0, -0.4), (-0.25 - 2 * tol, -1.0, -0.4), events.LOWER_HIT, 0),
    ]
    for (a0, rate0, b0), (a1, rate1, b1), flags_a, flags_b in cases:
        old, new = prepared.state.copy(), prepared.state.copy()
        old.theta[[a, b]], old.theta_dot[a] = (a0, b0), rate0
        new.theta[[a, b]], new.theta_dot[a] = (a1, b1), rate1
        flags = events.hinge_flags(assembler, old, new)
        assert (flags[a], flags[b]) == (flags_a, flags_b), (a1, b1)
        reached, crossing = events.lock_events(assembler, old, new)
        assert reached == ([b] if flags_b == events.LOCK_REACHED else [])
        assert [k for k, _ in crossing] == ([b] if flags_b == events.LOCK_CROSSED else [])
        assert [(k, side) for k, side, _ in events.stop_crossings(assembler, old, new)] == (
            [(a, 1)] if flags_a & events.UPPER_CROSSED else [(a, -1)] if flags_a & events.LOWER_CROSSED else [])
        hits, stops, _, rests = events.stop_hits(assembler, new, old)
        assert hits == ([a] if flags_a & (events.LOWER_HIT | events.UPPER_HIT) else [])
        assert rests == [abs(a0 - stop) <= tol for stop in stops]


def test_the_step_after_an_impact_starts_from_the_configuration_on_the_stop(tmp_path):
    """The impact moves the configuration onto the stop (timeloop/events.py hinge_stops) in the
    arrays of the state, which the compiled step views in place: it steps on from there, as the
    reference step does (before the fix it stepped on from the configuration before the impact,
    1e-7 off)."""
    compiled, compiled_summary = _run(stop_scene(0.5), tmp_path, "compiled", engine="compiled")
    python, python_summary = _run(stop_scene(0.5), tmp_path, "python", engine="reference")
    assert compiled_summary["engine"] == "compiled" and python_summary["engine"] == "reference"
    assert _relative_difference(compiled, python) <= 1e-10


def test_loop_hands_newton_failures_back(tmp_path, monkeypatch):
    """Three Newton iterations are not enough for this chain's large steps: steps are cut and
    regrown, in the Python loop, between runs of the C loop."""
    raw = hinged_chain(t_end=0.4, dt=0.02, max_iterations=3)
    raw["output"]["every"] = 0.04
    looped, stepped = _both(raw, tmp_path, monkeypatch, engine="compiled", newton="full")
    assert looped[1]["newton_cuts"] > 0
    _assert_same_run(looped, stepped)


def test_loop_reaches_modified_newton_results(tmp_path, monkeypatch):
    raw = hinged_chain(t_end=0.3)
    raw["output"]["every"] = 0.05
    looped, stepped = _both(raw, tmp_path, monkeypatch, engine="compiled", newton="modified")
    _assert_same_run(looped, stepped)


def law_chain(t_end=0.3, R=np.eye(3), shift=np.zeros(3), rotary=0.0):
    """The 3D chain with hinge laws in θ, θ̇ and t: a stiffening spring, a rate-dependent
    damper, a torque in θ and t, a table stiffness in t, a spring law in θ̇ (not conservative)."""
    raw = hinged_chain(R, shift, t_end=t_end, rotary=rotary)
    hinges = [raw["beams"][name]["start"]["hinge"] for name in ("l1", "l2", "l3")]
    hinges[0].update(stiffness="40*(1 + 2*theta**2)", damping="0.5 + 0.2*theta_dot**2",
                     torque="3*sin(5*t)*cos(theta)", rest_angle=0.1)
    hinges[1].update(stiffness={"table": [[0.0, 20.0], [0.1, 35.0], [0.2, 30.0]]}, damping=0.3,
                     torque="Piecewise((2*t, t < 0.15), (0.3, True))")
    hinges[2].update(stiffness="15 + 4*abs(theta_dot)", damping="0.1*(1 + Heaviside(theta))")
    raw["output"]["probes"]["strain"] = {"energy": "strain"}
    raw["output"]["probes"]["work"] = {"energy": "external_work"}
    return raw


def test_hinge_laws_in_theta_run_compiled_and_equal_the_reference_step(tmp_path):
    raw = law_chain()
    python, python_summary = _run(raw, tmp_path, "python", engine="reference")
    compiled, compiled_summary = _run(raw, tmp_path, "compiled", engine="compiled", newton="full")
    assert python_summary["engine"] == "reference" and compiled_summary["engine"] == "compiled"
    assert compiled_summary["time_loop"] == "compiled"
    for key in ("steps", "newton_iterations", "rejected_steps"):
        assert compiled_summary[key] == python_summary[key], key
    assert _relative_difference(python, compiled) <= 1e-10
    assert max(np.abs(python.probes["h1"])) > 0.05  # the laws were exercised away from zero


@pytest.mark.parametrize("rotary", [0.0, 2e-3])
@pytest.mark.parametrize("seed", [3, 17])
def test_loop_with_hinge_laws_is_invariant_under_rigid_motions(seed, rotary, tmp_path):
    """The law chain moved by a random rigid motion (hinge axes, gravity, points with it), with
    and without rotary inertia, in the compiled loop: the same hinge angles, and the tip moved
    with the scene (as tests/test_inertia.py holds the step without laws)."""
    R, shift = rigid_motion(seed)
    plain, plain_summary = _run(law_chain(rotary=rotary), tmp_path, "plain", engine="compiled")
    moved, moved_summary = _run(law_chain(R=R, shift=shift, rotary=rotary), tmp_path, "moved", engine="compiled")
    assert plain_summary["time_loop"] == moved_summary["time_loop"] == "compiled"
    for key in ("steps", "newton_iterations", "rejected_steps"):
        assert moved_summary[key] == plain_summary[key], key
    assert _compare(plain, moved, R, shift, points_global=("tip",), scalars=("h1", "h2", "h3", "kinetic", "strain")) < 1e-8


@pytest.mark.parametrize("scene", ["loaded_arm", "law_chain"])
def test_laws_that_cannot_be_compiled_are_called_back_in_python(scene, tmp_path, monkeypatch):
    """Without the laws' library the C code calls the laws back in Python (native_model.SceneLaws):
    the same run, still stepped in C (laws of time; hinge laws in θ, θ̇ and t)."""
    from latdyn.assembly import compiled_laws, native_model

    raw = loaded_arm(t_end=0.1) if scene == "loaded_arm" else law_chain()
    reference, _ = _run(raw, tmp_path, "compiled_laws", engine="compiled")

    def unavailable(*args, **kwargs):
        raise compiled_laws.LawsUnavailable("no compiler for the laws (test)")

    monkeypatch.setattr(native_model, "compile_laws", unavailable)
    result, summary = _run(raw, tmp_path, "python_laws", engine="compiled")
    assert summary["engine"] == "compiled" and summary["time_loop"] == "compiled"
    # the compiled hinge laws equal SymPy's lambdas to ~1e-13 per call (below), not bit for bit;
    # twenty-odd Newton solves a row carry that to ~1e-11 on the chain
    assert _relative_difference(reference, result) <= (1e-12 if scene == "loaded_arm" else 1e-10)


# ----------------------------------------------------------------------------- the laws alone

TIME_LAWS = [
    "Piecewise((0.4*t, t < 15), (6, True))",
    "0.5*(1 - cos(pi*t/3))*Heaviside(3 - t) + Heaviside(t - 3)",
    "Min(2*t, 1) + Max(sin(3*t), 0.2) - abs(t - 1.5)*sign(t - 2)",
    "exp(-t)*sqrt(1 + t**2) + atan2(t, 2) + t**(3/2) + tanh(t - 1)",
    "Piecewise((t**3, 1 < t < 2), (0, True))",
    "7.25",
    {"table": [[0.0, 0.0], [0.5, 2.0], [1.5, -1.0], [4.0, 3.0]]},
    {"table": [[1.0, 4.0]]},
]


def _compiled(time_functions, hinge_laws=()):
    from latdyn.assembly.compiled_laws import compile_laws

    compiled = compile_laws(list(time_functions), list(hinge_laws))
    time_laws = ctypes.CFUNCTYPE(None, ctypes.c_double, ctypes.c_void_p)(compiled.time_laws)
    hinge = ctypes.CFUNCTYPE(None, ctypes.c_int64, ctypes.c_double, ctypes.c_double, ctypes.c_double,
                             ctypes.c_void_p)(compiled.hinge_laws)
    return time_laws, hinge


def test_compiled_time_laws_equal_the_expressions():
    functions = [TimeFunction(source) for source in TIME_LAWS]
    time_laws, _ = _compiled(functions)
    rng = np.random.default_rng(4)
    times = np.r_[rng.uniform(-1.0, 5.0, 200), 0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 15.0, 16.0]
    out = np.zeros(3 * len(functions))
    for t in times:
        time_laws(float(t), out.ctypes.data)
        for k, f in enumerate(functions):
            expected = np.array([f.value(float(t)), f.rate(float(t)), f.accel(float(t))])
            assert out[3 * k: 3 * k + 3] == pytest.approx(expected, rel=1e-13, abs=1e-13, nan_ok=True), (TIME_LAWS[k], t)


def test_compiled_hinge_laws_equal_the_expressions():
    sources = ["40*(1 + 2*theta**2)", "0.5 + 0.2*theta_dot**2 + t*theta", "3*sin(5*t)*cos(theta) - theta_dot**3",
               "15 + 4*abs(theta_dot)*Heaviside(theta - 0.1)", 2.5, {"table": [[0.0, 1.0], [1.0, 3.0]]}]
    laws = [HingeLaw(source) for source in sources]
    _, hinge = _compiled([], laws)
    rng = np.random.default_rng(5)
    out = np.zeros(3)
    for theta, rate, t in rng.uniform(-2.0, 2.0, (100, 3)):
        for k, law in enumerate(laws):
            hinge(k, theta, rate, t, out.ctypes.data)
            expected = [law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t)]
            assert out == pytest.approx(expected, rel=1e-13, abs=1e-13, nan_ok=True), (sources[k], theta, rate, t)


def test_the_laws_unit_is_stamped_and_reproducible():
    from codegen.emit import MARKER
    from latdyn.assembly.compiled_laws import hinge_law, time_law
    from codegen.laws import laws_source

    functions = [TimeFunction(source) for source in TIME_LAWS]
    laws = [HingeLaw("40*(1 + 2*theta**2)")]
    first = laws_source([time_law(f) for f in functions], [hinge_law(h) for h in laws])
    again = laws_source([time_law(copy.deepcopy(f)) for f in functions], [hinge_law(h) for h in laws])
    assert first == again and MARKER in first.splitlines()[1]
    assert "Piecewise((0.4*t, t < 15), (6, True))" in first  # each law's source as its comment
