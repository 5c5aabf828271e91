"""A clamped 3D truss beam with rigid joints: the lattice problem of ``benchmarks/peers.py``.

One problem, three codes (latdyn, Exudyn, OpenSeesPy), each built from the same geometry:

- a square-section truss beam of ``bays`` bays (pitch ``PITCH`` along x, width ``WIDTH``);
  station i (x = i·PITCH) has four corner joints c{i}_{k}, k = 0…3 at (y, z) = (0, 0),
  (b, 0), (b, b), (0, b); station 0 is clamped (its joints fixed);
- every bay i (stations i → i + 1) adds 12 members: 4 longerons c{i}_k → c{i+1}_k, 4 battens
  round station i + 1, and one diagonal per face (bottom z = 0 and top z = b parallel to each
  other, sides y = 0 and y = b parallel to each other, so that bending about y does not
  twist the section);
- members are aluminium tubes (E 70 GPa, G 26 GPa, ρ 2700 kg/m³; longerons Ø25×1.5 mm,
  battens and diagonals Ø20×1.0 mm), shear-deformable (GA = κ G A, κ = 0.5 for a thin
  tube), with their rotary inertia ρI, ρJ;
- joints are rigid and massless: all members meeting at a joint share its translation and
  rotation (latdyn: a joint body of no mass; OpenSeesPy: a shared node; Exudyn: every member
  has its own end node with the member's axes, welded to the joint's other member nodes);
- load: a smooth force pulse F0 sin²(πt/tp) along z, split equally over the four tip joints, of peak
  ``F0`` and duration ``T/2``, then free vibration until ``t_end = 2 T``; ``T`` estimates the
  first bending period: the equivalent cantilever (EI = E A_longeron b², shear stiffness of
  the two side faces as pin-jointed panels, mass per length of all members), bending and
  shear frequencies combined by Dunkerley's formula (within 7 % of latdyn's first mode from
  4 to 64 bays); ``F0`` gives a static tip deflection of L/1000 on that beam. Both scale
  with the length, so every size sees the same number of periods.

Output: the tip transverse displacement u(t) = mean z-displacement of the four tip joints,
recorded every step.  Error (:func:`error`): the largest deviation of u(t) from the
converged reference history over the whole run (0 … 2T), divided by the reference's largest
|u|: amplitude and phase alike (the first peak and u at T, 1.5 T, 2 T are reported beside it).
The reference histories, and how they were obtained, are in
``benchmarks/references/lattice.json`` (:func:`make_reference`).
"""
from __future__ import annotations

import ctypes
import importlib.util
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import yaml


ROOT = Path(__file__).resolve().parents[1]
REFERENCE_FILE = ROOT / "benchmarks" / "references" / "lattice.json"

PITCH = 0.5     # m, bay length a
WIDTH = 0.5     # m, side b of the square section
E, G, RHO = 70e9, 26e9, 2700.0   # aluminium
KAPPA = 0.5     # shear coefficient of a thin circular tube
TUBES = {"longeron": (0.025, 0.0015), "batten": (0.020, 0.0010), "diagonal": (0.020, 0.0010)}
CORNERS = ((0.0, 0.0), (WIDTH, 0.0), (WIDTH, WIDTH), (0.0, WIDTH))
SAMPLE_TIMES = (1.0, 1.5, 2.0)   # in units of T: where u(t) enters the error


def tube(outer: float, wall: float) -> dict:
    """Section values of a circular tube (SI)."""
    ro, ri = outer / 2, outer / 2 - wall
    A = math.pi * (ro ** 2 - ri ** 2)
    I = math.pi / 4 * (ro ** 4 - ri ** 4)
    return {"A": A, "I": I, "J": 2 * I, "EA": E * A, "EI": E * I, "GJ": G * 2 * I, "GA": KAPPA * G * A,
            "rhoA": RHO * A, "rhoI": RHO * I, "rhoJ": RHO * 2 * I}


SECTIONS = {name: tube(*dims) for name, dims in TUBES.items()}


def corner(i: int, k: int) -> str:
    return f"c{i}_{k}"


def joints(bays: int) -> dict:
    """Joint name -> position, stations 0 … bays."""
    return {corner(i, k): (i * PITCH, y, z) for i in range(bays + 1) for k, (y, z) in enumerate(CORNERS)}


def members(bays: int) -> list:
    """(name, start joint, end joint, section) of every member, bay by bay (none joins two
    clamped joints: station 0 has no battens)."""
    out = []
    for i in range(bays):
        for k in range(4):
            out.append((f"l{i}_{k}", corner(i, k), corner(i + 1, k), "longeron"))
        for k in range(4):
            out.append((f"b{i + 1}_{k}", corner(i + 1, k), corner(i + 1, (k + 1) % 4), "batten"))
        out.append((f"d{i}_bottom", corner(i, 0), corner(i + 1, 1), "diagonal"))
        out.append((f"d{i}_top", corner(i, 3), corner(i + 1, 2), "diagonal"))
        out.append((f"d{i}_side0", corner(i, 0), corner(i + 1, 3), "diagonal"))
        out.append((f"d{i}_side1", corner(i, 1), corner(i + 1, 2), "diagonal"))
    return out


def is_fixed(joint: str) -> bool:
    return joint.startswith("c0_")


def tip_joints(bays: int) -> list:
    return [corner(bays, k) for k in range(4)]


def equivalent_beam(bays: int) -> dict:
    """The equivalent cantilever: EI, shear stiffness GA of the two side faces, mass per length,
    first period T (Dunkerley: 1/ω² = 1/ω_bending² + 1/ω_shear²), load F0, pulse length tp, t_end."""
    L = bays * PITCH
    EI = SECTIONS["longeron"]["EA"] * WIDTH ** 2   # 4 longerons at b/2 from both axes: Σ A d² = A b²
    diag = math.hypot(PITCH, WIDTH)
    # a side face (a panel a × b, one diagonal, a batten) in shear, pin-jointed:
    # 1/GA_face = d³/(a b² EA_d) + b/(a EA_b); the two side faces carry the shear along z
    flex = diag ** 3 / (PITCH * WIDTH ** 2 * SECTIONS["diagonal"]["EA"]) + WIDTH / (PITCH * SECTIONS["batten"]["EA"])
    GA = 2 / flex
    m = (4 * PITCH * SECTIONS["longeron"]["rhoA"] + 4 * WIDTH * SECTIONS["batten"]["rhoA"]
         + 4 * diag * SECTIONS["diagonal"]["rhoA"]) / PITCH
    omega_b = 1.8751040687 ** 2 * math.sqrt(EI / (m * L ** 4))
    omega_s = math.pi / 2 * math.sqrt(GA / (m * L ** 2))
    omega = 1 / math.sqrt(1 / omega_b ** 2 + 1 / omega_s ** 2)
    T = 2 * math.pi / omega
    F0 = (L / 1000) / (L ** 3 / (3 * EI) + L / GA)   # static tip deflection L/1000
    return {"L": L, "EI": EI, "GA": GA, "m": m, "T": T, "F0": F0, "tp": T / 2, "t_end": 2 * T}


def pulse(t: float, F0: float, tp: float) -> float:
    """The load history: F0 sin²(π t / tp) for 0 < t < tp, then 0 (a smooth bump of length tp)."""
    if t <= 0 or t >= tp:
        return 0.0
    return F0 * math.sin(math.pi * t / tp) ** 2


def pulse_expression(F0: float, tp: float) -> str:
    return f"Piecewise(({F0!r}*sin(pi*t/{tp!r})**2, t < {tp!r}), (0, True))"


def pulse_table(F0: float, tp: float, t_end: float, samples: int = 400) -> tuple:
    """(times, values) of the pulse, for codes that take a piecewise linear load history."""
    t = np.linspace(0.0, tp, samples + 1)
    return list(t) + [10 * t_end], [pulse(x, F0, tp) for x in t] + [0.0]


def counts(bays: int, elements: int) -> dict:
    """Model sizes: members, beam elements, latdyn coordinates (6 per free joint and inner node)."""
    nm = 12 * bays
    return {"bays": bays, "members": nm, "elements": nm * elements,
            "coordinates": 6 * (4 * bays + nm * (elements - 1))}


# ----------------------------------------------------------------------------- latdyn
def latdyn_scene(bays: int, elements: int, dt: float, *, t_end: float | None = None, method=None,
                 rho_inf=None, newton=None, formulation=None, engine=None, tol=None, every=None,
                 load: str = "pulse", analysis: str = "transient", shear: bool = True,
                 rotary: bool = True) -> dict:
    """The scene mapping (as YAML holds it). ``load``: "pulse" (the benchmark) or "static" (the
    peak force held constant, for ``analysis: static``).  ``shear``/``rotary``: False leaves out
    the sections' GA (Euler–Bernoulli members) / rotary inertia (as OpenSeesPy's elements)."""
    from latdyn.scene.builder import SceneBuilder  # here: an Exudyn-only process does not import latdyn

    eq = equivalent_beam(bays)
    b = SceneBuilder(f"clamped 3D truss beam, {bays} bays, rigid joints, tip pulse")
    for name, s in SECTIONS.items():
        b.section(name, EA=s["EA"], EIy=s["EI"], EIz=s["EI"], GJ=s["GJ"], rhoA=s["rhoA"],
                  rhoIy=s["rhoI"] if rotary else None, rhoIz=s["rhoI"] if rotary else None,
                  GAy=s["GA"] if shear else None, GAz=s["GA"] if shear else None)
    for name, at in joints(bays).items():
        b.body(name, at, fixed=is_fixed(name))
    for name, start, end, section in members(bays):
        b.beam(name, start, end, section, elements=elements)
    force = pulse_expression(eq["F0"] / 4, eq["tp"]) if load == "pulse" else eq["F0"] / 4
    for k, joint in enumerate(tip_joints(bays)):
        b.load(joint, force=[0.0, 0.0, force])
        b.probe(f"u{k}", point=joint, quantity="displacement", frame="global", component="z")
    solve = {"analysis": analysis}
    if analysis == "transient":
        solve.update(t_end=t_end or eq["t_end"], dt=dt)
        for key, value in (("method", method), ("rho_inf", rho_inf), ("newton", newton), ("engine", engine),
                           ("tol", tol)):
            if value is not None:
                solve[key] = value
    if formulation:
        solve["formulation"] = formulation
    b.solve(**solve)
    b.output(every=(every if every is not None else dt) if analysis == "transient" else None, paraview_every=0)
    return b.to_dict()


def scene_yaml(bays: int, elements: int, dt: float, **kw) -> str:
    """The scene as YAML text (what a user writes to a file for ``latdyn run``)."""
    return yaml.safe_dump(latdyn_scene(bays, elements, dt, **kw), sort_keys=False, default_flow_style=None,
                          width=140)


def tip_mean(table) -> np.ndarray:
    return np.mean([np.asarray(table[f"u{k}"], float) for k in range(4)], axis=0)


# ----------------------------------------------------------------------------- error
def peak(t, y, window):
    """Largest value of y for t in window, refined by a parabola through three samples."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    idx = np.flatnonzero((t >= window[0] - 1e-12) & (t <= window[1] + 1e-12))
    i = idx[int(np.argmax(y[idx]))]
    if 0 < i < len(t) - 1:
        t0, t1, t2 = t[i - 1:i + 2]
        y0, y1, y2 = y[i - 1:i + 2]
        a = np.polyfit([t0 - t1, 0.0, t2 - t1], [y0, y1, y2], 2)
        if a[0] < 0:
            tp = -a[1] / (2 * a[0])
            if t0 - t1 <= tp <= t2 - t1:
                return float(np.polyval(a, tp)), float(t1 + tp)
    return float(y[i]), float(t[i])


def values(bays: int, t, u) -> dict:
    """The measured quantities of one run: first peak of u (within the first period) and u at
    the sample times (linear interpolation in the recorded rows)."""
    T = equivalent_beam(bays)["T"]
    t, u = np.asarray(t, float), np.asarray(u, float)
    u_peak, t_peak = peak(t, u, (0.0, T))
    out = {"u_peak": u_peak, "t_peak": t_peak}
    for s in SAMPLE_TIMES:
        out[f"u_{s:g}T"] = float(np.interp(s * T, t, u))
    return out


def load_reference() -> dict:
    if REFERENCE_FILE.exists():
        return json.loads(REFERENCE_FILE.read_text())
    return {"bays": {}}


def history_deviation(t, u, t_ref, u_ref) -> float:
    """max over the run's rows of |u − u_ref| / max |u_ref|, u_ref a cubic spline through the
    reference history (recorded every step of a much finer run) at the run's own times."""
    from scipy.interpolate import CubicSpline

    t, u = np.asarray(t, float), np.asarray(u, float)
    spline = CubicSpline(np.asarray(t_ref, float), np.asarray(u_ref, float))
    keep = t <= t_ref[-1] * (1 + 1e-12)
    return float(np.max(np.abs(u[keep] - spline(t[keep]))) / np.max(np.abs(u_ref)))


def error(bays: int, t, u, reference: dict | None = None, physics: str = "timoshenko"):
    """(error, parts) of one run against the stored reference of this size ((None, {}) where
    there is none).  error = the largest deviation of the tip history from the reference,
    relative to the reference's largest |u| (:func:`history_deviation`); parts: that, and the
    relative errors of the first peak and of u at the sample times.  ``physics``: "timoshenko"
    (the problem: shear-deformable members with rotary inertia) or "euler_bernoulli" (the
    same members shear-rigid, without rotary inertia: the model OpenSeesPy's elasticBeamColumn
    solves)."""
    reference = load_reference() if reference is None else reference
    ref = reference.get("bays", {}).get(str(bays), {}).get(physics)
    if ref is None:
        return None, {}
    h = ref["history"]
    parts = {"history": history_deviation(t, u, h["t"], h["u"])}
    vals = values(bays, t, u)
    scale = abs(ref["values"]["u_peak"])
    for k, v in ref["values"].items():
        if k.startswith("u_"):
            parts[k] = abs(vals[k] - v) / scale
    return parts["history"], parts


# ----------------------------------------------------------------------------- frames
def member_frame(a, b) -> np.ndarray:
    """Rotation matrix whose columns are the member's local x (along it), y, z; y as latdyn's
    default (global Z × x, else global Y)."""
    x = np.asarray(b, float) - np.asarray(a, float)
    x /= np.linalg.norm(x)
    y = np.cross([0.0, 0.0, 1.0], x)
    if np.linalg.norm(y) < 1e-12:
        y = np.array([0.0, 1.0, 0.0])
    y -= x * (x @ y)
    y /= np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


# ----------------------------------------------------------------------------- Exudyn
def exudyn_model(exu, eii, bays: int, elements: int, model: str = "beam"):
    """Exudyn model of the lattice; returns (SystemContainer, mbs, tip sensors).

    ``model = "beam"``: ``ObjectBeamGeometricallyExact`` elements on ``NodeRigidBodyEP``
    nodes.  Exudyn's element takes its reference configuration as the straight beam along the
    local x axis of its nodes (h0 = [L, 0, 0, 0, 0, 0]), so every member has its own nodes,
    carrying the member's axes; at a joint the end nodes of the members meeting there are
    welded to the first member's end node by ``GenericJoint``s with all six axes constrained
    (rotation markers = the nodes' reference rotations, so the weld holds the relative
    rotation of t = 0), and at a clamped joint each end node to ground.
    Section: stiffness diag(EA, GA, GA, GJ, EI, EI), inertia diag(ρJ, ρI, ρI), ρA.

    ``model = "rbs"``: a rigid-body–spring model without constraints (but the Euler
    parameters'): a rigid body (``NodeRigidBodyEP``) at every joint and every inner node of
    a member (``elements`` segments a member), each segment of length h a
    ``RigidBodySpringDamper`` of stiffness diag(EA, GA, GA, GJ, EI, EI)/h in the member's
    axes, acting at the segment's midpoint; each body carries the mass ρA·h/2 and rotary
    inertia of the half segments that meet at it (the rod's ρA h³/24 transverse besides ρI h/2,
    turned into global axes and summed over the members at a joint).  Clamped joints are the
    ground.
    """
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    J = joints(bays)
    if model == "rbs":
        return _exudyn_rbs(exu, eii, SC, mbs, bays, elements, J)
    sections = {}
    for name, s in SECTIONS.items():
        sec = exu.BeamSection()
        sec.stiffnessMatrix = np.diag([s["EA"], s["GA"], s["GA"], s["GJ"], s["EI"], s["EI"]])
        sec.inertia = np.diag([s["rhoJ"], s["rhoI"], s["rhoI"]])
        sec.massPerLength = s["rhoA"]
        sections[name] = sec
    from exudyn.rigidBodyUtilities import RotationMatrix2EulerParameters
    ground = mbs.AddObject(eii.ObjectGround())
    at_joint: dict[str, list] = {}   # joint -> [(node, R)]
    for name, a, b, sec in members(bays):
        pa, pb = np.asarray(J[a]), np.asarray(J[b])
        R = member_frame(pa, pb)
        ep = list(RotationMatrix2EulerParameters(R))
        h = float(np.linalg.norm(pb - pa)) / elements
        nodes = [mbs.AddNode(eii.NodeRigidBodyEP(referenceCoordinates=list(pa + (pb - pa) * i / elements) + ep))
                 for i in range(elements + 1)]
        for i in range(elements):
            mbs.AddObject(eii.ObjectBeamGeometricallyExact(nodeNumbers=[nodes[i], nodes[i + 1]],
                                                           physicsLength=h, sectionData=sections[sec]))
        at_joint.setdefault(a, []).append((nodes[0], R))
        at_joint.setdefault(b, []).append((nodes[-1], R))
    for joint, ends in at_joint.items():
        n0, R0 = ends[0]
        m0 = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=n0))
        if is_fixed(joint):
            for n, R in ends:
                mg = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=list(J[joint])))
                mn = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=n))
                mbs.AddObject(eii.GenericJoint(markerNumbers=[mg, mn], constrainedAxes=[1] * 6,
                                               rotationMarker0=np.eye(3), rotationMarker1=R.T))
            continue
        for n, R in ends[1:]:
            mn = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=n))
            # marker frames: node axes turned back to global axes at t = 0 (both = I globally)
            mbs.AddObject(eii.GenericJoint(markerNumbers=[m0, mn], constrainedAxes=[1] * 6,
                                           rotationMarker0=R0.T, rotationMarker1=R.T))
    loads_at = [at_joint[j][0][0] for j in tip_joints(bays)]
    return _exudyn_finish(exu, eii, SC, mbs, bays, [("node", n) for n in loads_at])


def _exudyn_rbs(exu, eii, SC, mbs, bays, elements, J):
    ground = mbs.AddObject(eii.ObjectGround())
    # nodes: joints and inner points, with lumped mass and inertia (global axes, t = 0)
    mass: dict = {}
    inertia: dict = {}
    pos: dict = {}
    segments = []   # (key a, key b, midpoint, R, stiffness)
    for name, a, b, sec in members(bays):
        s = SECTIONS[sec]
        pa, pb = np.asarray(J[a]), np.asarray(J[b])
        R = member_frame(pa, pb)
        h = float(np.linalg.norm(pb - pa)) / elements
        keys = [a] + [f"{name}.{i}" for i in range(1, elements)] + [b]
        for i, key in enumerate(keys):
            pos[key] = pa + (pb - pa) * i / elements
        half_m = s["rhoA"] * h / 2
        # half segment of length h/2, about the body's point at its end: rod inertia + section
        It = s["rhoA"] * (h / 2) ** 3 / 3 + s["rhoI"] * h / 2
        Ix = s["rhoJ"] * h / 2
        Ilocal = R @ np.diag([Ix, It, It]) @ R.T
        K = np.diag([s["EA"], s["GA"], s["GA"], s["GJ"], s["EI"], s["EI"]]) / h
        for i in range(elements):
            for key in (keys[i], keys[i + 1]):
                mass[key] = mass.get(key, 0.0) + half_m
                inertia[key] = inertia.get(key, np.zeros((3, 3))) + Ilocal
            segments.append((keys[i], keys[i + 1], (pos[keys[i]] + pos[keys[i + 1]]) / 2, R, K))
    from exudyn.utilities import RigidBodyInertia
    bodies = {}
    for key in pos:
        if key in J and is_fixed(key):
            continue
        # inertia about the body's reference point (joint or node); no offset of the centre of mass
        bodies[key] = mbs.CreateRigidBody(referencePosition=list(pos[key]), referenceRotationMatrix=np.eye(3),
                                          inertia=RigidBodyInertia(mass=mass[key], inertiaTensor=inertia[key]),
                                          nodeType=exu.NodeType.RotationEulerParameters)
    for ka, kb, mid, R, K in segments:
        markers = []
        for key in (ka, kb):
            if key in bodies:
                markers.append(mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=bodies[key],
                                                                 localPosition=list(mid - pos[key]))))
            else:
                markers.append(mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=list(mid))))
        mbs.AddObject(eii.RigidBodySpringDamper(markerNumbers=markers, stiffness=K, rotationMarker0=R,
                                                rotationMarker1=R))
    return _exudyn_finish(exu, eii, SC, mbs, bays, [("body", bodies[j]) for j in tip_joints(bays)])


def _exudyn_finish(exu, eii, SC, mbs, bays, tips):
    eq = equivalent_beam(bays)
    F, tp = eq["F0"] / 4, eq["tp"]
    sensors = []
    disp = exu.OutputVariableType.Displacement
    for kind, number in tips:
        if kind == "node":
            marker = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=number))
            sensors.append(mbs.AddSensor(eii.SensorNode(nodeNumber=number, outputVariableType=disp,
                                                        storeInternal=True, writeToFile=False)))
        else:
            marker = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=number, localPosition=[0, 0, 0]))
            sensors.append(mbs.AddSensor(eii.SensorBody(bodyNumber=number, localPosition=[0, 0, 0],
                                                        outputVariableType=disp, storeInternal=True,
                                                        writeToFile=False)))
        mbs.AddLoad(eii.Force(markerNumber=marker, loadVector=[0, 0, 0],
                              loadVectorUserFunction=lambda mbs, t, load, F=F, tp=tp: [0, 0, pulse(t, F, tp)]))
    mbs.Assemble()
    return SC, mbs, sensors


def exudyn_settings(exu, bays: int, cfg: dict):
    """Exudyn's SimulationSettings of a lattice run (cfg: dt, t_end, rho_inf, modified, atol, rtol,
    threads), no solution file (peers.py times the solver; peers_as_user.py turns it on)."""
    t_end = cfg.get("t_end") or equivalent_beam(bays)["t_end"]
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.numberOfSteps = int(round(t_end / cfg["dt"]))
    ti.endTime = t_end
    ti.verboseMode = 0
    ti.generalizedAlpha.spectralRadius = cfg.get("rho_inf", 0.8)
    ti.newton.useModifiedNewton = cfg.get("modified", True)
    if cfg.get("atol") is not None:
        ti.newton.absoluteTolerance = cfg["atol"]
    if cfg.get("rtol") is not None:
        ti.newton.relativeTolerance = cfg["rtol"]
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = cfg["dt"]
    ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    ss.parallel.numberOfThreads = cfg.get("threads", 1)
    return ss


def exudyn_run(exu, eii, bays: int, cfg: dict) -> dict:
    """Build and solve; the row fields of peers.py (solver_s: SolveSystem; run_s: build + solve)."""
    import warnings

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        SC, mbs, sensors = exudyn_model(exu, eii, bays, cfg["elements"], cfg.get("model", "beam"))
    ss = exudyn_settings(exu, bays, cfg)
    solver = exu.MainSolverImplicitSecondOrder()
    t1 = time.perf_counter()
    try:
        ok, msg = solver.SolveSystem(mbs, ss), ""
    except Exception as exc:  # Exudyn raises on some failures
        ok, msg = False, str(exc)[:200]
    t2 = time.perf_counter()
    it = solver.it
    out = {"solver_s": t2 - t1, "run_s": t2 - t0, "compile_s": None, "steps": int(it.currentStepIndex),
           "newton_iterations": int(it.newtonStepsCount), "jacobian_updates": int(it.newtonJacobiCount),
           "coordinates": int(mbs.systemData.ODE2Size()), "constraints": len(mbs.systemData.GetAECoordinates())}
    data = [mbs.GetSensorStoredData(s) for s in sensors]
    t = data[0][:, 0]
    if not ok:
        out.update(status="failed", note=msg or f"SolveSystem returned False at t = {t[-1]:.4g} s")
        return out
    u = np.mean([d[:, 3] for d in data], axis=0)
    out.update(status="ok", t=t, u=u)
    return out


# ----------------------------------------------------------------------------- OpenSeesPy
OPENSEES_MISSING = ("OpenSeesPy is not installed: no OpenSeesPy rows.  `pip install openseespy` (the "
                    "`peers` extra) and rerun.")


def import_opensees():
    """``openseespy.opensees``, or None.  The Linux wheel ships libblas/liblapack/libgfortran in
    ``openseespylinux/lib`` but does not find them without a system BLAS: load them first."""
    spec = importlib.util.find_spec("openseespylinux")
    if spec is not None and spec.origin:
        lib = Path(spec.origin).parent / "lib"
        for name in ("libquadmath.so.0", "libgfortran.so.4", "libgfortran.so.5", "libblas.so.3", "liblapack.so.3",
                     "libgomp.so.1"):
            if (lib / name).exists():
                try:
                    ctypes.CDLL(str(lib / name), mode=ctypes.RTLD_GLOBAL)
                except OSError:
                    pass
    try:
        import openseespy.opensees as ops
    except Exception:  # ImportError, or its RuntimeError('Failed to import openseespy on Linux.')
        return None
    return ops


def opensees_version(ops) -> str | None:
    try:
        return str(ops.version())
    except Exception:
        return None


def opensees_run(ops, bays: int, cfg: dict) -> dict:
    """OpenSeesPy model and transient run.

    Nodes at the joints (shared by the members: rigid joints) and at the members' inner
    points; ``elasticBeamColumn`` elements (E, G, A, J, I, I of the tube; Euler–Bernoulli: no
    shear deformation, no rotary inertia — its mass is ρA, consistent with ``-cMass``) with a
    ``Corotational`` transformation (vecxz = the member's local z of :func:`member_frame`);
    ``fix`` at station 0.  HHT-α (``HHT alpha``, the dissipation of ρ∞), ``ModifiedNewton``
    (``cfg["algorithm"]``: also "ModifiedNewton -initial", "Newton"), ``UmfPack``, ``RCM``,
    ``Plain`` constraints, ``NormDispIncr`` test with tolerance ``tol``·L (as latdyn's
    increment test, relative to the length); the load a ``Path`` time series (the sin² pulse
    sampled at 401 points) on the four tip nodes.  One ``analyze(1, dt)`` per step from Python,
    the tip displacement read with ``nodeDisp`` after each.
    """
    eq = equivalent_beam(bays)
    t_end = cfg.get("t_end") or eq["t_end"]
    dt, elements = cfg["dt"], cfg["elements"]
    t0 = time.perf_counter()
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    J = joints(bays)
    tag = {}
    for k, (name, p) in enumerate(J.items(), start=1):
        tag[name] = k
        ops.node(k, *p)
        if is_fixed(name):
            ops.fix(k, 1, 1, 1, 1, 1, 1)
    next_node = len(J) + 1
    transf = 0
    element = 0
    for name, a, b, sec in members(bays):
        s = SECTIONS[sec]
        pa, pb = np.asarray(J[a]), np.asarray(J[b])
        R = member_frame(pa, pb)
        transf += 1
        ops.geomTransf("Corotational", transf, *R[:, 2])
        chain = [tag[a]]
        for i in range(1, elements):
            ops.node(next_node, *(pa + (pb - pa) * i / elements))
            chain.append(next_node)
            next_node += 1
        chain.append(tag[b])
        for i in range(elements):
            element += 1
            ops.element("elasticBeamColumn", element, chain[i], chain[i + 1], s["A"], E, G, s["J"], s["I"], s["I"],
                        transf, "-mass", s["rhoA"], "-cMass")
    times, factors = pulse_table(1.0, eq["tp"], t_end)
    ops.timeSeries("Path", 1, "-time", *times, "-values", *factors)
    ops.pattern("Plain", 1, 1)
    tips = [tag[j] for j in tip_joints(bays)]
    for n in tips:
        ops.load(n, 0.0, 0.0, eq["F0"] / 4, 0.0, 0.0, 0.0)
    rho = cfg.get("rho_inf", 0.8)
    # HHT-α with the dissipation of ρ∞ (OpenSees's alpha = 1 − α_HHT, α_HHT = (1 − ρ∞)/(1 + ρ∞));
    # its GeneralizedAlpha is not used: on this lattice, even with a Linear transformation, Newton
    # took ~10 iterations a step and the run diverged (its update() hands the elements the
    # acceleration at t + Δt where the tangent assumes that at t + α_M Δt)
    ops.integrator("HHT", 1 - (1 - rho) / (1 + rho))
    ops.constraints("Plain")
    ops.numberer("RCM")
    ops.system("UmfPack")
    ops.test("NormDispIncr", cfg.get("tol", 1e-8) * eq["L"], cfg.get("max_iterations", 50))
    algorithm = cfg.get("algorithm", "ModifiedNewton")
    ops.algorithm(*algorithm.split())
    ops.analysis("Transient")
    n = int(round(t_end / dt))
    t = np.zeros(n + 1)
    u = np.zeros(n + 1)
    iterations = 0
    t1 = time.perf_counter()
    status = "ok"
    note = ""
    for step in range(1, n + 1):
        if ops.analyze(1, dt) != 0:
            status, note = "failed", f"analyze failed at t = {step * dt:.4g} s"
            t, u = t[:step], u[:step]
            break
        iterations += ops.testIter()
        t[step] = ops.getTime()
        u[step] = sum(ops.nodeDisp(k, 3) for k in tips) / 4
    t2 = time.perf_counter()
    out = {"status": status, "note": note, "solver_s": t2 - t1, "run_s": t2 - t0, "compile_s": None,
           "steps": len(t) - 1, "newton_iterations": iterations, "jacobian_updates": None,
           "coordinates": 6 * (next_node - 1 - 4), "t": t, "u": u}
    ops.wipe()
    return out


# ----------------------------------------------------------------------------- latdyn run
def latdyn_run(latdyn, bays: int, cfg: dict) -> dict:
    """``latdyn.run`` of the scene in process (no results folder); the row fields of peers.py."""
    s = latdyn_scene(bays, cfg["elements"], cfg["dt"], t_end=cfg.get("t_end"), method=cfg.get("method"),
                     rho_inf=cfg.get("rho_inf"), newton=cfg.get("newton"), formulation=cfg.get("formulation"),
                     engine=cfg.get("engine"), tol=cfg.get("tol"), shear=cfg.get("shear", True),
                     rotary=cfg.get("rotary", True))
    t0 = time.perf_counter()
    try:
        r = latdyn.run(s)
    except latdyn.SolverError as exc:
        return {"status": "failed", "note": str(exc).splitlines()[0][:200], "run_s": time.perf_counter() - t0}
    run_s = time.perf_counter() - t0
    sm = r.summary
    solver_s = sm.get("solver_s")
    if solver_s is None:
        solver_s = sm["wall_time_s"] - (sm.get("compile_s") or 0.0)
    return {"status": "ok", "run_s": run_s, "solver_s": solver_s, "compile_s": sm.get("compile_s"),
            "steps": sm.get("steps"), "newton_iterations": sm.get("newton_iterations"),
            "jacobian_updates": sm.get("jacobian_updates", sm.get("factorizations")),
            "step_cuts": sm.get("newton_cuts"), "backend": sm.get("backend"), "engine": sm.get("engine"),
            "newton_mode": sm.get("newton"), "method": sm.get("method"), "tol": sm.get("newton_tolerance"),
            "coordinates": sm.get("coordinates"), "summary": sm,
            "t": np.asarray(r.t), "u": tip_mean(r.probes)}


# ----------------------------------------------------------------------------- reference
#: The reference runs: latdyn with reference_elements(bays) elements a member (8 below 8 bays, where
#: the members' own vibrations are in the response, 2 from 128 bays on) and dt = T/REFERENCE_STEPS, default
#: formulation, full Newton; a run at half the elements and twice the step shows how far it is
#: converged; Exudyn and OpenSeesPy at fine settings cross-check it.
REFERENCE_STEPS = 800


def reference_elements(bays: int) -> int:
    return 8 if bays < 8 else (4 if bays < 128 else 2)


def _history(t, u, digits: int = 9) -> dict:
    return {"t": [float(f"{x:.{digits}g}") for x in t], "u": [float(f"{x:.{digits}g}") for x in u]}


def make_reference(bays_list, latdyn, exu=None, eii=None, ops=None, log=print, recompute: bool = False) -> dict:
    """Converged tip histories per size (both physics), with the checks; merged into
    ``REFERENCE_FILE`` after every run (sizes not in ``bays_list``, and runs already stored, are
    kept unless ``recompute``)."""
    doc = load_reference()
    doc.setdefault("bays", {})
    doc["how"] = ("latdyn (solve.formulation default, full Newton, generalized-alpha rho_inf 0.8) with "
                  "reference_elements(bays) elements a member (8 below 8 bays, 4 below 128, else 2) and dt = T/800, "
                  "recorded every step; 'timoshenko': the benchmark's members (GA = 0.5 G A, rotary "
                  "inertia rho I); 'euler_bernoulli': the same members shear-rigid without rotary inertia "
                  "(what OpenSeesPy's elasticBeamColumn models).  'checks': the largest deviation of other "
                  "runs' histories from the reference, relative to its largest |u|: latdyn at half the "
                  "elements and twice the step (convergence), Exudyn geometrically exact beams and "
                  "OpenSeesPy elasticBeamColumn/Corotational at fine settings (cross-checks).  Made by "
                  "`python benchmarks/lattice.py --reference --bays ...`.")

    def save():
        REFERENCE_FILE.parent.mkdir(parents=True, exist_ok=True)
        REFERENCE_FILE.write_text(json.dumps(doc, indent=None, separators=(",", ":")) + "\n")

    for bays in bays_list:
        eq = equivalent_beam(bays)
        e = reference_elements(bays)
        entry = doc["bays"].get(str(bays)) if not recompute else None
        if entry is None or entry.get("elements") != e:
            entry = {}
        entry.update({"T": eq["T"], "t_end": eq["t_end"], "F0": eq["F0"], "tp": eq["tp"], "elements": e,
                      "dt": eq["T"] / REFERENCE_STEPS})
        entry.setdefault("checks", {})
        doc["bays"][str(bays)] = entry
        for physics, extra in (("timoshenko", {}), ("euler_bernoulli", {"shear": False, "rotary": False})):
            if physics in entry:
                continue
            t0 = time.perf_counter()
            r = latdyn_run(latdyn, bays, dict(elements=e, dt=eq["T"] / REFERENCE_STEPS, **extra))
            if r["status"] != "ok":
                raise RuntimeError(f"reference run failed: {bays} bays, {physics}: {r.get('note')}")
            entry[physics] = {"values": values(bays, r["t"], r["u"]), "history": _history(r["t"], r["u"]),
                              "solver_s": r["solver_s"], "load_average": os.getloadavg()[0]}
            save()
            log(f"reference {bays} bays {physics}: {e} el/member, dt T/{REFERENCE_STEPS}: "
                f"{time.perf_counter() - t0:.1f} s, peak {entry[physics]['values']['u_peak']:.7g}")
        ref_doc = {"bays": {str(bays): entry}}
        half = max(1, e // 2)
        checks = [("latdyn_half", "timoshenko", lambda: latdyn_run(latdyn, bays, dict(
                      elements=half, dt=2 * eq["T"] / REFERENCE_STEPS)),
                   f"latdyn {half} el/member, dt T/{REFERENCE_STEPS // 2}"),
                  ("latdyn_eb_vs_timoshenko", "timoshenko", None, "the euler_bernoulli reference")]
        # Exudyn's element converges slowly where the members vibrate (below 8 bays); an absolute
        # Newton tolerance of 1e-6 F0 stalled it at 64 bays (minutes of Jacobian updates): 1e-4 F0
        ee = 32 if bays < 8 else (4 if bays < 128 else 2)
        if exu is not None:
            checks.append(("exudyn_beam", "timoshenko", lambda: exudyn_run(exu, eii, bays, dict(
                elements=ee, dt=2 * eq["T"] / REFERENCE_STEPS, atol=1e-4 * eq["F0"])),
                f"Exudyn ObjectBeamGeometricallyExact {ee} el/member, dt T/{REFERENCE_STEPS // 2}, "
                f"modified Newton, abs tol 1e-4 F0"))
        eo = e if bays < 8 else (2 if bays < 128 else 1)
        if ops is not None:
            checks.append(("opensees_vs_euler_bernoulli", "euler_bernoulli", lambda: opensees_run(ops, bays, dict(
                elements=eo, dt=2 * eq["T"] / REFERENCE_STEPS, tol=1e-10)),
                f"OpenSeesPy elasticBeamColumn/Corotational {eo} el/member, dt T/{REFERENCE_STEPS // 2}, "
                f"HHT, ModifiedNewton, tol 1e-10 L"))
        for name, physics, run, what in checks:
            if entry["checks"].get(name, {}).get("what") == what:
                continue
            t0 = time.perf_counter()
            if run is None:
                h = entry["euler_bernoulli"]["history"]
                t, u = h["t"], h["u"]
            else:
                r = run()
                if r["status"] != "ok":
                    entry["checks"][name] = {"what": what, "status": r["status"], "note": r.get("note")}
                    log(f"check {bays} bays {name}: {r['status']} {r.get('note')}")
                    save()
                    continue
                t, u = r["t"], r["u"]
            dev, _ = error(bays, t, u, ref_doc, physics)
            entry["checks"][name] = {"what": what, "against": physics, "deviation": dev,
                                     "values": values(bays, t, u)}
            save()
            log(f"check {bays} bays {name} ({what}) against {physics}: deviation {dev:.2e} "
                f"({time.perf_counter() - t0:.1f} s, load {os.getloadavg()[0]:.2f})")
    return doc


def _import_codes():
    import sys

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from peers import exu, eii, latdyn, _quiet_exudyn  # noqa: E402  (latdyn from this checkout)

    if exu is not None:
        _quiet_exudyn()
    return latdyn, exu, eii, import_opensees()


def main(argv=None) -> int:
    import argparse

    ap = argparse.ArgumentParser(description="The lattice problem's converged reference (see the module).")
    ap.add_argument("--reference", action="store_true", help="compute and store the reference histories")
    ap.add_argument("--bays", default="4,16,64", help="sizes, comma-separated")
    args = ap.parse_args(argv)
    if not args.reference:
        ap.print_help()
        return 0
    latdyn, exu, eii, ops = _import_codes()
    make_reference([int(b) for b in args.bays.split(",")], latdyn, exu, eii, ops,
                   log=lambda m: print(m, flush=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
