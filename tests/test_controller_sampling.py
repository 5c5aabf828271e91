"""The sampled controllers' sample compiled and taken in the loop of steps (SCENE.md
``controllers.NAME.rate``; latdyn/timeloop/sampling.py, csrc/sampling.c).

References: the sample written out in Python from the controllers' SymPy expressions (``math``
lambdas, :meth:`latdyn.scene.controllers.Controller.functions`: the implementation the C cycle
replaced, kept here only as the reference) at random states; and the same runs with every step and
every sample taken from Python (``latdyn.timeloop.transient.COMPILED_LOOP = False``: the time loop
samples through the same compiled cycle and restarts with ``consistent_acceleration``'s inertia split),
on genuinely 3D and planar flexible arms and on models with rigid links and guides (the restart on the
minimum coordinates); the exact discrete-time solutions (a guided cart here) of sampled loops on a
rigid hub are tests/test_controllers.py's and tests/test_stepping.py's. Scenes are YAML text."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.timeloop import transient as transient_module

#: A flexible arm (rotary inertia: every direction has inertia, the loop restarts after a sample in C)
#: on a hinge about AXIS under gravity, a tip body, two sampled controllers: a PI with tip feedback
#: (50 Hz, saturated) and a second one at 100 Hz reading the first by name and through its probe, its
#: state's probe, an input, a velocity and t.
ARM = """
title: a flexible arm under sampled control
gravity: {gravity}
inputs: {{ref: 0.6}}
controllers:
  pic:
    output: "-8*(th - ref) - 2*om - 20*(tip_y - 0.05) - 4*S"
    states: {{S: "th - ref"}}
    initial: {{S: 0.1}}
    rate: 50
    limits: [-3, 3]
  ff:
    output: "0.5*pic + 0.1*pi_out + 0.2*tip_v - Sp + 0.01*t"
    states: {{F: "pic - F"}}
    rate: 100
sections:
  rod: {{EA: 1.0e6, EIy: 40.0, EIz: 60.0, GJ: 30.0, rhoA: 2.0, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [1.0, 0.2, 0.1], mass: 0.3, inertia: [0.001, 0.002, 0.001]}}
beams:
  arm:
    from: base
    to: tip
    section: rod
    elements: 3
    start: {{hinge: {{axis: {axis}, torque: "pic + 0.3*ff", damping: 0.05}}}}
solve: {{t_end: {t_end}, dt: 0.005}}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
    om: {{hinge: arm.start, quantity: rate}}
    tip_y: {{point: tip, quantity: displacement, component: y}}
    tip_v: {{point: tip, quantity: velocity, component: {velocity}}}
    pi_out: {{controller: pic}}
    ff_out: {{controller: ff}}
    Sp: {{controller: pic, state: S}}
    Fp: {{controller: ff, state: F}}
"""
SPATIAL = dict(gravity="[0, 0, -9.81]", axis="[0, 0.6, 0.8]", velocity="z")
PLANAR = dict(gravity="[0, -9.81, 0]", axis="[0, 0, 1]", velocity="x")


def arm(kind: dict, t_end: float = 0.6) -> dict:
    text = ARM.format(t_end=t_end, **kind)
    if kind is PLANAR:  # in the plane: the tip in it
        text = text.replace("at: [1.0, 0.2, 0.1]", "at: [1.0, 0.2, 0]")
    return yaml.safe_load(text)


def reference_sample(scene, probes, state, t: float) -> None:
    """The sample at ``t`` as it was written in Python (module docstring): the probes' values at
    ``state``, then controller by controller in file order y = clip(output), S ← S + EXPR/rate, a
    controller's output read through its probe or its name being the current (new) value."""
    values = dict(zip(probes.names, probes.values(state)))
    outputs, states, inputs = scene.controller_outputs, scene.controller_states, scene.inputs
    by_name = {p.name: p for p in scene.output.probes}
    for c in scene.controllers.values():
        if not c.sampled or abs(round(t * c.rate) / c.rate - t) > 1e-12:
            continue

        def signal(name):
            probe = by_name.get(name)
            if probe is not None and probe.kind == "controller":
                return outputs[probe.controller] if probe.state is None else states[f"{probe.controller}.{probe.state}"]
            if name in values:
                return values[name]
            return inputs[name] if name in inputs else outputs[name]

        tk = round(t * c.rate) / c.rate
        own = [states[f"{c.name}.{s}"] for s in c.states]
        arguments = [tk, *(signal(n) for n in c.reads), *own]
        output, rates = c.functions()
        steps = [float(f(*arguments)) / c.rate for f in rates]
        outputs.values[outputs.index(c.name)] = c.clip(float(output(*arguments)))
        for s, value, step in zip(c.states, own, steps):
            states.values[states.index(f"{c.name}.{s}")] = value + step


@pytest.mark.parametrize("kind", [SPATIAL, PLANAR], ids=["3d", "planar"])
def test_the_compiled_sample_equals_the_python_reference_at_random_states(kind):
    """At 20 random states (angles, rates, node positions and velocities perturbed) and instants, the
    held outputs and the states after ``NativeModel.sample`` equal the reference's to round-off
    (measured: 3.3e-16 relative, 3D and planar)."""
    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    prepared = prepare(latdyn.load_scene(arm(kind)))
    scene, assembler = prepared.scene, prepared.assembler
    probes = ProbeSet(assembler, prepared.state)
    native = assembler.native()
    assert native.provided == []  # every probe read has a C sensor
    rng = np.random.default_rng(3)
    worst = 0.0
    for trial in range(20):
        state = prepared.state.copy()
        free = assembler.model.free_nodes
        state.theta[:] += rng.normal(0, 0.5, state.theta.shape)
        state.theta_dot[:] += rng.normal(0, 2.0, state.theta_dot.shape)
        state.x[free] += rng.normal(0, 0.05, state.x[free].shape)
        state.v[free] += rng.normal(0, 1.0, state.v[free].shape)
        state.w[free] += rng.normal(0, 1.0, state.w[free].shape)
        t = [0.0, 0.02, 0.01, 0.37, 0.5][trial % 5]
        scene.controller_outputs.values[:] = rng.normal(0, 1, len(scene.controller_outputs.values))
        scene.controller_states.values[:] = rng.normal(0, 1, len(scene.controller_states.values))
        start = scene.controller_outputs.values.copy(), scene.controller_states.values.copy()
        reference_sample(scene, probes, state, t)
        expected = scene.controller_outputs.values.copy(), scene.controller_states.values.copy()
        scene.controller_outputs.values[:], scene.controller_states.values[:] = start
        state.t = t
        assert native.sample(state, t, 1e-12) == (2 if abs(t * 50 - round(t * 50)) < 1e-9 else 1)
        for got, want in zip((scene.controller_outputs.values, scene.controller_states.values), expected):
            worst = max(worst, float(np.max(np.abs(got - want) / np.maximum(1.0, np.abs(want)))))
    assert worst <= 1e-14, worst


def run_probes(scene: dict, compiled: bool, monkeypatch) -> tuple[dict, dict, int]:
    """The run's probes and summary, and the calls of the loop of steps in C."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha

    calls = []
    advance = CompiledGeneralizedAlpha.advance

    def counted(self, *args, **kwargs):
        calls.append(kwargs.get("grid_index"))
        return advance(self, *args, **kwargs)

    with monkeypatch.context() as m:
        m.setattr(transient_module, "COMPILED_LOOP", compiled)
        m.setattr(CompiledGeneralizedAlpha, "advance", counted)
        result = latdyn.run(latdyn.load_scene(scene))
    return result.probes, result.summary, len(calls)


@pytest.mark.parametrize("kind", [SPATIAL, PLANAR], ids=["3d", "planar"])
def test_sampled_in_the_loop_of_steps_equals_the_python_loop(kind, monkeypatch):
    """The arm sampled at 50 and 100 Hz for 0.6 s (dt 0.005; 90 samples): the loop of steps in C samples
    and restarts on every instant without returning (its calls: the 256-step blocks), and every probe
    of every row equals the run stepped and sampled from Python bit for bit: its restart is the same C
    (csrc/sampling.c sample_restart, CompiledGeneralizedAlpha.restart_after_sample). It was the inertia
    split of ``consistent_acceleration`` before, 2.8e-12 (3D) and 1.7e-12 (planar) off at most: the restart's LU
    of M against the split's solve, grown through the closed loop's 120 steps."""
    scene = arm(kind)
    native, summary, calls = run_probes(scene, True, monkeypatch)
    python, reference, _ = run_probes(scene, False, monkeypatch)
    assert summary["time_loop"] == "compiled" and reference["time_loop"] == "python"
    assert calls == 1  # 120 steps, 90 samples: one call (the rows recorded where the loop runs)
    assert summary["steps"] == reference["steps"] == 120
    assert summary["newton_iterations"] == reference["newton_iterations"]
    for name in python:
        assert native[name].tobytes() == python[name].tobytes(), name
    assert np.ptp(python["th"]) > 0.05 and np.max(np.abs(python["pi_out"])) == 3.0  # it moved, saturated
    assert len(np.unique(python["ff_out"])) == 61  # held: one value per 100 Hz sample


def test_a_probe_without_a_c_sensor_is_handed_in_and_the_loop_stops_on_the_instants(monkeypatch):
    """A sampled controller that reads the kinetic energy (no C sensor) and a section moment (its C sensor):
    the loop of steps in C stops on each of its instants and the time loop hands the energy's value to the
    same compiled cycle; the run equals the one stepped from Python to round-off."""
    scene = arm(SPATIAL, t_end=0.3)
    scene["output"]["probes"]["kin"] = {"energy": "kinetic"}
    scene["output"]["probes"]["bend"] = {"element": "arm.element[0]", "quantity": "moment_y"}
    scene["controllers"]["ff"]["output"] = "0.5*pic - 2*kin + 0.01*bend"
    native, summary, calls = run_probes(scene, True, monkeypatch)
    python, _, _ = run_probes(scene, False, monkeypatch)
    assert summary["time_loop"] == "compiled" and calls >= 30  # one call per 100 Hz instant
    for name in python:
        scale = max(1.0, float(np.max(np.abs(python[name]))))
        assert np.max(np.abs(native[name] - python[name])) <= 1e-11 * scale, name


#: A free body of mass 2 (and inertia: every direction has inertia, no rigid link: the loop of steps
#: restarts after each sample in C) pushed along the unit direction d by a sampled PI on its
#: displacement s = d·u and rate along d: m s̈ = u exactly, a double integrator with a zero-order hold.
PUCK = """
inputs: {{kp: 6.0, kd: 2.0, ki: 1.0, ref: 1.0}}
controllers:
  ctl:
    output: "-kp*(s - ref) - kd*sd - ki*S"
    states: {{S: "s - ref"}}
    initial: {{S: 0.5}}
    rate: 10
bodies:
  puck: {{at: [0.2, 0.4, -0.3], mass: 2.0, inertia: [0.2, 0.3, 0.4]}}
loads:
  - {{at: puck, force: ["{d0}*ctl", "{d1}*ctl", "{d2}*ctl"]}}
solve: {{t_end: 3.0, dt: 0.025}}
output:
  probes:
    x: {{point: puck, quantity: displacement, component: x}}
    y: {{point: puck, quantity: displacement, component: y}}
    z: {{point: puck, quantity: displacement, component: z}}
    vx: {{point: puck, quantity: velocity, component: x}}
    vy: {{point: puck, quantity: velocity, component: y}}
    vz: {{point: puck, quantity: velocity, component: z}}
    u: {{controller: ctl}}
"""


@pytest.mark.parametrize("d", [(1.0, 0.0, 0.0), (1 / 3, 2 / 3, 2 / 3)], ids=["axis", "skew"])
def test_a_sampled_pi_restarted_in_the_loop_equals_the_exact_discrete_time_solution(d, monkeypatch):
    """The PI sampled at 10 Hz, dt = 0.025 (four steps a sample), through the loop of steps
    in C that samples and restarts itself: at each of the 31 instants s and ṡ equal the exact solution
    s_{k+1} = s_k + T ṡ_k + u_k T²/2m, ṡ_{k+1} = ṡ_k + u_k T/m to round-off (measured 4.4e-16 m and
    8.9e-16 m/s along x, 6.7e-16 / 6.7e-16 along the skew d), and the motion stays along d."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha

    scene = yaml.safe_load(PUCK.format(d0=d[0], d1=d[1], d2=d[2]))
    # s and ṡ along d: the probes' combination inside the law
    scene["controllers"]["ctl"]["output"] = (f"-kp*(({d[0]}*x + {d[1]}*y + {d[2]}*z) - ref)"
                                             f" - kd*({d[0]}*vx + {d[1]}*vy + {d[2]}*vz) - ki*S")
    scene["controllers"]["ctl"]["states"] = {"S": f"({d[0]}*x + {d[1]}*y + {d[2]}*z) - ref"}
    restarted = []
    natively = CompiledGeneralizedAlpha.restarts_natively
    monkeypatch.setattr(CompiledGeneralizedAlpha, "restarts_natively",
                        lambda self, state: restarted.append(natively(self, state)) or restarted[-1])
    result = latdyn.run(latdyn.load_scene(scene))
    assert result.summary["time_loop"] == "compiled" and restarted and all(restarted)
    p = result.probes
    s = d[0] * p["x"] + d[1] * p["y"] + d[2] * p["z"]
    sd = d[0] * p["vx"] + d[1] * p["vy"] + d[2] * p["vz"]
    T, m, th, om, S = 0.1, 2.0, 0.0, 0.0, 0.5
    for k in range(31):
        row = int(np.argmin(np.abs(result.t - k * T)))
        assert abs(result.t[row] - k * T) < 1e-12
        assert abs(s[row] - th) < 1e-13 and abs(sd[row] - om) < 1e-13, (k, s[row] - th, sd[row] - om)
        u = -6.0 * (th - 1.0) - 2.0 * om - 1.0 * S
        if k < 30:
            assert abs(p["u"][row] - u) < 1e-11
        S = S + (th - 1.0) / 10
        th, om = th + T * om + u * T * T / (2 * m), om + u * T / m
    across = np.column_stack([p["x"], p["y"], p["z"]]) - np.outer(s, d)
    assert np.max(np.abs(across)) < 1e-12


def test_modified_newton_and_laws_called_back_in_python_sample_as_the_compiled_run(monkeypatch):
    """``solve.newton: modified`` (the restart factorizes M in a storage of its own: the held
    factorization of the iteration matrix stays) against its run stepped from Python; and without the
    laws' library (the sampled laws called back in Python, native_model.SceneLaws) against the
    compiled laws: the same rows to round-off."""
    from latdyn.assembly import compiled_laws, native_model

    scene = arm(SPATIAL, t_end=0.3)
    scene["solve"]["newton"] = "modified"
    native, summary, calls = run_probes(scene, True, monkeypatch)
    python, reference, _ = run_probes(scene, False, monkeypatch)
    assert calls == 1 and summary["factorizations"] == reference["factorizations"] < summary["steps"]
    for name in python:
        assert np.max(np.abs(native[name] - python[name])) <= 1e-11 * max(1.0, np.max(np.abs(python[name]))), name

    def unavailable(*args, **kwargs):
        raise compiled_laws.LawsUnavailable("no compiler for the laws (test)")

    scene["solve"].pop("newton")
    compiled, _, _ = run_probes(scene, True, monkeypatch)
    monkeypatch.setattr(native_model, "compile_laws", unavailable)
    called_back, summary, _ = run_probes(scene, True, monkeypatch)
    assert summary["time_loop"] == "compiled"
    for name in compiled:
        assert np.max(np.abs(called_back[name] - compiled[name])) <= 1e-10 * max(1.0, np.max(np.abs(compiled[name]))), name


@pytest.mark.parametrize("where", ["arm", "puck", "linked"])
def test_sampled_in_the_loop_resumes_bit_for_bit(where, tmp_path, monkeypatch):
    """Interrupted between two samples and resumed (the loop of steps sampling and restarting in C):
    probes.csv equals an uninterrupted run's, byte for byte."""
    from test_checkpoint import interrupt_at

    if where == "arm":
        scene = arm(PLANAR, t_end=0.5)
    elif where == "linked":  # the restart on the minimum coordinates (defined below)
        scene = yaml.safe_load(LINKED.format(**LINKED_SPATIAL))
    else:
        scene = yaml.safe_load(PUCK.format(d0=1 / 3, d1=2 / 3, d2=2 / 3))
        scene["controllers"]["ctl"]["output"] = "-kp*(x - ref) - kd*vx - ki*S"
        scene["controllers"]["ctl"]["states"] = {"S": "x - ref"}
    full, out = tmp_path / "full", tmp_path / "out"
    latdyn.run(scene, full)
    with monkeypatch.context() as m:
        interrupt_at(m, 0.337)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    assert (out / "probes.csv").read_text() == (full / "probes.csv").read_text()


#: A 3D beam without rotary inertia on a skew hinge: its elements' twist has an inertia ~ φ² of their
#: bending (none while straight), which the inertia split counts massless or not as the state goes.
TWIST = """
controllers:
  ctl: {output: "-20*(th - 0.2)", rate: 100}
sections:
  s: {EA: 1.0e6, EIy: 100.0, EIz: 100.0, GJ: 80.0, rhoA: 1.0}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: hub, to: [2, 0, 0], section: s, elements: 8, start: {hinge: {axis: [0, 0.6, 0.8], torque: ctl}}}
initial_velocity: {angular: [0, 0.03, 0.04]}
solve: {t_end: 0.3, dt: 0.002}
output:
  every: 0.01
  probes:
    th: {hinge: arm.start, quantity: angle}
    om: {hinge: arm.start, quantity: rate}
"""


def test_a_twist_without_rotary_inertia_restarts_from_python_as_the_python_loop(monkeypatch):
    """The restart after each sample of the beam without rotary inertia is the time loop's (the split
    at each sample: measured, the loop's own M⁻¹ restart once the bending gave the twist an inertia
    diverged from it by 1e-2 rad at t = 0.6): the loop of steps samples in C and returns after each
    sample, and the rows equal the run stepped from Python bit for bit."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha

    natively = CompiledGeneralizedAlpha.restarts_natively
    seen = []
    monkeypatch.setattr(CompiledGeneralizedAlpha, "restarts_natively",
                        lambda self, state: seen.append(natively(self, state)) or seen[-1])
    scene = yaml.safe_load(TWIST)
    native, summary, calls = run_probes(scene, True, monkeypatch)
    python, reference, _ = run_probes(scene, False, monkeypatch)
    assert seen and not any(seen) and summary["time_loop"] == "compiled"
    assert summary["steps"] == reference["steps"] and calls >= 30
    for name in python:
        assert np.array_equal(native[name], python[name]), name


#: A body B guided along a skew axis (spring, damper, the sampled PI's force) carrying a rigid link to a
#: body D on a skew hinge (spring, a share of the PI's torque), a flexible beam D-E with rotary inertia
#: beyond it: B and D are dependent nodes, the restart after each sample is on the minimum coordinates
#: with Pᵀ M P (csrc/links.c assemble_linked_mass). The PI (50 Hz, saturated) reads the slide, its rate
#: and the hinge angle.
LINKED = """
gravity: {gravity}
controllers:
  ctl:
    output: "-30*(sB - 0.1) - 4*sBd - 12*S - 2*th"
    states: {{S: "sB - 0.1"}}
    rate: 50
    limits: [-12, 12]
sections:
  s: {{EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.5}}
  f: {{EA: 1.0e5, EIy: 20.0, EIz: 30.0, GJ: 15.0, rhoA: 0.8, rhoIy: 0.002, rhoIz: 0.002}}
bodies:
  B: {{at: [0.3, 0.1, {zb}], mass: 0.7, inertia: [0.01, 0.02, 0.03], com: [0, 0.05, 0],
      guide: {{axis: {guide_axis}, stiffness: 40.0, damping: 0.5, force: ctl}}}}
  D: {{at: [0.8, -0.3, {zd}], mass: 0.4, inertia: [0.01, 0.01, 0.02]}}
  E: {{at: [1.3, -0.1, {ze}], mass: 0.1, inertia: [0.001, 0.001, 0.001]}}
beams:
  l: {{from: B, to: D, section: s, rigid: true,
      start: {{hinge: {{axis: {hinge_axis}, stiffness: 9.0, torque: "0.3*ctl"}}}}}}
  fl: {{from: D, to: E, section: f, elements: 2}}
solve: {{t_end: 0.4, dt: 0.005}}
output:
  probes:
    sB: {{guide: B, quantity: position}}
    sBd: {{guide: B, quantity: rate}}
    th: {{hinge: l.start, quantity: angle}}
    om: {{hinge: l.start, quantity: rate}}
    Dz: {{point: D, quantity: displacement, component: {across}}}
    Dv: {{point: D, quantity: velocity, component: {across}}}
    Ey: {{point: E, quantity: displacement, component: y}}
    u: {{controller: ctl}}
    Sp: {{controller: ctl, state: S}}
"""
LINKED_SPATIAL = dict(gravity="[0, 0, -9.81]", zb=0.2, zd=0.6, ze=0.5, guide_axis="[1, 2, 2]",
                      hinge_axis="[0.2, -1, 0.4]", across="z")
LINKED_PLANAR = dict(gravity="[0, -9.81, 0]", zb=0, zd=0, ze=0, guide_axis="[1, 2, 0]", hinge_axis="[0, 0, 1]",
                     across="x")


def counting_restarts(monkeypatch) -> list:
    """What :meth:`CompiledGeneralizedAlpha.restarts_natively` answered, call by call."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha

    seen = []
    natively = CompiledGeneralizedAlpha.restarts_natively
    monkeypatch.setattr(CompiledGeneralizedAlpha, "restarts_natively",
                        lambda self, state: seen.append(natively(self, state)) or seen[-1])
    return seen


@pytest.mark.parametrize("kind", [LINKED_SPATIAL, LINKED_PLANAR], ids=["3d", "planar"])
def test_a_linked_and_guided_model_restarts_in_the_loop_as_the_python_loop(kind, monkeypatch):
    """A guide, a rigid link and a flexible beam under a sampled PI at 50 Hz for 0.4 s (80 steps,
    20 samples): the loop of steps in C samples and restarts on the minimum coordinates without returning
    (one call), and every probe of every row equals the run stepped from Python bit for bit (its restart the
    same C, csrc/sampling.c sample_restart; before, ``consistent_acceleration`` with the reduced Pᵀ M P of
    latdyn.assembly.linked, 4.2e-13 and 4.8e-13 off at most: the restart's LU of Pᵀ M P against the split's
    solve, grown through the closed loop)."""
    seen = counting_restarts(monkeypatch)
    scene = yaml.safe_load(LINKED.format(**kind))
    native, summary, calls = run_probes(scene, True, monkeypatch)
    python, reference, _ = run_probes(scene, False, monkeypatch)
    assert seen and all(seen) and summary["time_loop"] == "compiled" and reference["time_loop"] == "python"
    assert calls == 1 and summary["steps"] == reference["steps"] == 80
    assert summary["newton_iterations"] == reference["newton_iterations"]
    for name in python:
        assert native[name].tobytes() == python[name].tobytes(), name
    assert np.ptp(python["sB"]) > 0.05 and np.ptp(python["th"]) > 0.05 and len(np.unique(python["u"])) == 21


#: A cart of mass 2 on a guide along the skew axis [1, 2, 2] (its com off the body's point: the guide
#: keeps its orientation, m s̈ = u exactly), pushed along it by a sampled PI on its slide and rate.
SLIDE = """
inputs: {kp: 6.0, kd: 2.0, ki: 1.0, ref: 1.0}
controllers:
  ctl:
    output: "-kp*(s1 - ref) - kd*s1d - ki*S"
    states: {S: "s1 - ref"}
    initial: {S: 0.5}
    rate: 10
bodies:
  cart: {at: [0.2, 0.4, -0.3], mass: 2.0, inertia: [0.2, 0.3, 0.4], com: [0.1, 0.05, 0],
         guide: {axis: [1, 2, 2], force: ctl}}
solve: {t_end: 3.0, dt: 0.025}
output:
  probes:
    s1: {guide: cart, quantity: position}
    s1d: {guide: cart, quantity: rate}
    u: {controller: ctl}
"""


def test_a_sampled_pi_on_a_guide_restarted_in_the_loop_equals_the_exact_discrete_time_solution(tmp_path,
                                                                                                monkeypatch):
    """The PI at 10 Hz on the guided cart, dt = 0.025, through ``python -m latdyn run`` (the loop of steps
    samples and restarts on the guide's coordinate in C): at each of the 31 instants s and ṡ equal the
    exact solution s_{k+1} = s_k + T ṡ_k + u_k T²/2m, ṡ_{k+1} = ṡ_k + u_k T/m (measured 1.2e-15 m and
    1.2e-15 m/s), u_k the PI's."""
    from cli_runs import latdyn_run, probe_columns

    seen = counting_restarts(monkeypatch)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(SLIDE)))
    assert result.summary["time_loop"] == "compiled" and seen and all(seen)
    T, m, s, sd, S = 0.1, 2.0, 0.0, 0.0, 0.5
    p = result.probes
    for k in range(31):
        row = int(np.argmin(np.abs(result.t - k * T)))
        assert abs(result.t[row] - k * T) < 1e-12
        assert abs(p["s1"][row] - s) < 1e-13 and abs(p["s1d"][row] - sd) < 1e-13, (k, p["s1"][row] - s)
        u = -6.0 * (s - 1.0) - 2.0 * sd - 1.0 * S
        if k < 30:
            assert abs(p["u"][row] - u) < 1e-11
        S = S + (s - 1.0) / 10
        s, sd = s + T * sd + u * T * T / (2 * m), sd + u * T / m
    completed, out = latdyn_run(tmp_path, SLIDE, quiet=True)
    assert completed.returncode == 0, completed.stderr
    cli = probe_columns(out)
    for name in ("s1", "s1d", "u"):
        assert np.max(np.abs(cli[name] - p[name])) <= 1e-15 * max(1.0, np.max(np.abs(p[name]))), name


def test_a_linked_model_under_modified_newton_keeps_its_held_factorization_through_the_restarts(monkeypatch):
    """``solve.newton: modified`` on the guided and linked model: the restart's Pᵀ M P is assembled and
    factorized in a storage of its own, so the iteration matrix's held factorization survives the 20
    samples: the same factorizations as the run stepped from Python (fewer than the steps) and the same
    rows to round-off."""
    scene = yaml.safe_load(LINKED.format(**LINKED_SPATIAL))
    scene["solve"]["newton"] = "modified"
    native, summary, calls = run_probes(scene, True, monkeypatch)
    python, reference, _ = run_probes(scene, False, monkeypatch)
    assert calls == 1 and summary["factorizations"] == reference["factorizations"] < summary["steps"]
    for name in python:
        assert np.max(np.abs(native[name] - python[name])) <= 1e-11 * max(1.0, np.max(np.abs(python[name]))), name


def test_a_rigid_slider_crank_restarts_in_the_loop_as_the_python_loop(monkeypatch):
    """The rigid slider-crank of tests/test_slider_crank.py (closure edges: the rod and the slider are
    functions of the pin) in the plane turned in space, its crank driven by a sampled PD at 50 Hz with
    limits: restarted in C on its one coordinate (Pᵀ M P through the closure's expansions), one call of
    the loop of steps for 25 samples, every row equal to the run stepped from Python bit for bit (the same C
    restart; 1.4e-17 rad in θ and 7.6e-17 rad/s in θ̇ off before, with the split's)."""
    from test_slider_crank import TURN, rigid_slider_crank

    probes = ("    crank: {hinge: crank.start, quantity: angle}\n    om: {hinge: crank.start, quantity: rate}\n"
              "    u: {controller: ctl}\n")
    scene = yaml.safe_load(rigid_slider_crank(TURN, "torque: ctl", "t_end: 0.5, dt: 0.005", probes, pin_mass=5.0))
    scene["controllers"] = {"ctl": {"output": "-20*(crank - 1.0) - 3*om", "rate": 50, "limits": [-4, 4]}}
    seen = counting_restarts(monkeypatch)
    native, summary, calls = run_probes(scene, True, monkeypatch)
    python, reference, _ = run_probes(scene, False, monkeypatch)
    assert seen and all(seen) and calls == 1 and summary["newton_iterations"] == reference["newton_iterations"]
    for name in python:
        assert native[name].tobytes() == python[name].tobytes(), name
    assert np.ptp(python["crank"]) > 0.9 and np.max(np.abs(python["u"])) == 4.0
