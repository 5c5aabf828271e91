"""What exact transient sensitivities cost: 0, 1, 10 and 100 (1000) parameters, forward and adjoint.

    python benchmarks/transient_sensitivities_cost.py [--repeats 3]
        [--scene cantilever|lattice|lattice1000|boom_latch|lattice_latch]
        [--parts | --phases K | --reverse-parts K | --richardson NAME]

A 3D cantilever of 30 elements (EIy != EIz, rotary inertia, tilted out of every coordinate plane)
carries fifty point loads at its nodes, the i-th with two components of amplitudes ``F<2i>`` and
``F<2i+1>`` (named parameters, 100 in all) growing linearly in time, and is stepped 40 steps of generalized-α (dt = 0.002); two probes at the tip, a row every 5
steps. The same scene is run in process without sensitivities (the loop of steps in C), without
them on the per-step path a sensitivity run takes (every step from Python, ``COMPILED_LOOP`` off),
with ``solve.sensitivities: [F0]``, ``[F0, …, F9]`` and ``[F0, …, F99]`` by the forward method and by the discrete
adjoint (``solve.sensitivity_method: adjoint``: each probe's end, max and min only), kernels and laws compiled
before, the cases interleaved ``--repeats`` times (the machine may be shared). ``--scene lattice1000``: the
lattice of 250 bays, 1000 member sections, with 1, 10, 100 and 1000 parameters. Per accepted step the
sensitivities add one evaluation of M, C and the exact K (the elements' inertia tangent by
``newton: exact``'s evaluation), one factorization and k back-substitutions, and the kernels of
∂r/∂p (latdyn/analyses/transient_sensitivities.py). The adjoint's forward pass only stores each step (the
per-step path); its reverse pass adds per stored step the same evaluation of M, C and the exact K, the
forward method's factorization of the step's matrix solved transposed for the outputs' columns, and one
batched (∂r/∂p)ᵀw of every parameter (latdyn/analyses/adjoint_sensitivities.py). Printed: the minimum and
median wall time of ``latdyn.run``, and of the CPU time of the process (steadier on a shared machine; the
native evaluation's OpenMP threads count in it above the parallel threshold — the lattice of 1000 members —,
and on a loaded machine their waits inflate it: ``OMP_NUM_THREADS=1`` measures without them), each with the
ratio of the minima to the run without; the 1-minute load average with them. ``--parts`` times the forward step's
pieces one by one (:func:`parts`), ``--phases K`` a forward run's pieces inside the run
(:func:`phases`; docs/performance.md, "Forward sensitivities: where a step goes"), ``--reverse-parts K`` a reverse step's pieces (docs/parameters.md, "The discrete
adjoint", has the figures), ``--richardson NAME`` checks the adjoint by NAME against Richardson-extrapolated
differences of whole runs (:func:`richardson`). ``--scene boom_latch`` and ``--scene lattice_latch``: deployments
that latch (:func:`latching_boom`, :func:`lattice_latch`; docs/parameters.md, "The discrete adjoint", "Events").

Measured (docs/parameters.md, "Transient sensitivities", cost; CPU minima of 5 passes at load 5.2–8.0 on the
2-core machine, main c7bcb6f in the same rounds): 1, 10, 100 parameters 4.3×, 4.5×, 6.5× the run without on
the cantilever (main: 4.5×, 4.8×, 7.6×) and 2.8×, 3.0×, 4.1× on the lattice (main: 3.1×, 3.2×, 4.7×); the
adjoint 4.2×, 3.9×, 4.1× and 2.6×, 2.7×, 3.0× (main: 4.1×, 4.0×, 4.1× and 2.8×, 2.9×, 3.0×). The step's
matrix S is summed, factorised in the storage the run's own iteration matrix has (band, the same order and
bandwidth) and its columns formed and solved in one native call (csrc/sensitivity_step.c; 0.082 ms with one
column on the cantilever), the predicted parts and the update in one each; the piece that sets the floor is
the native evaluation with the elements' inertia tangent (0.54–0.57 ms on the cantilever, ≈ 1.0× a step of
the run without), which the run's Newton iteration cannot share (it never evaluates at the converged state),
with the per-step path (1.1–1.2×): ≈ 2.2× before the rest of the step. A later round (docs/performance.md,
"Forward sensitivities: where a step goes": ``--phases``, CPU minima at load 2.3–2.8, main 2350dca in the same
minutes): lattice 2.83/3.13/4.30× → 2.65/2.83/3.99×, cantilever 4.13/4.36/5.98× → 3.97/4.24/5.87×.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import statistics
import time

import latdyn
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.timeloop import transient


def scene(names: list[str]) -> dict:
    loads = [{"at": f"arm.node[{1 + i % 30}]", "force": [f"0.1*F{2 * i}*t", f"-F{2 * i + 1}*t", f"0.3*F{2 * i}*t"]}
             for i in range(50)]
    solve = {"analysis": "transient", "dt": 0.002, "t_end": 0.08, **({"sensitivities": names} if names else {})}
    return {"parameters": {f"F{i}": 5.0 + 0.2 * i for i in range(100)},
            "sections": {"s": {"EA": 1e6, "EIy": 50.0, "EIz": 80.0, "GJ": 40.0, "rhoA": 1.0,
                               "rhoIy": 0.01, "rhoIz": 0.02}},
            "bodies": {"base": {"at": [0, 0, 0], "fixed": True}},
            "beams": {"arm": {"from": "base", "to": [3.0, 1.0, 0.5], "section": "s", "elements": 30}},
            "loads": loads, "solve": solve,
            "output": {"every": 0.01,
                       "probes": {"tip_z": {"point": "arm.end", "quantity": "position", "component": "z"},
                                  "tip_y": {"point": "arm.end", "quantity": "displacement", "component": "y"}}}}


def lattice(names: list[str], bays: int = 25) -> dict:
    """``--scene lattice``: a planar lattice cantilever of 25 bays (100 tubes of 1 element, each its own
    section whose EA is the parameter ``F<i>``: a lattice's member sections), a tip load growing in time,
    40 steps; ``--scene lattice1000``: 250 bays, 1000 tubes."""
    nodes, members = {}, {}
    for i in range(bays + 1):
        nodes[f"b{i}"], nodes[f"t{i}"] = [0.2 * i, 0.0, 0.0], [0.2 * i, 0.2, 0.0]
    for i in range(bays):
        for name, (a, b) in (("bottom", (f"b{i}", f"b{i + 1}")), ("top", (f"t{i}", f"t{i + 1}")),
                             ("diagonal", (f"b{i}", f"t{i + 1}")), ("vertical", (f"b{i + 1}", f"t{i + 1}"))):
            members[f"{name}{i}"] = (a, b)
    solve = {"analysis": "transient", "dt": 0.002, "t_end": 0.08, **({"sensitivities": names} if names else {})}
    return {"parameters": {f"F{i}": 2.0e6 for i in range(len(members))},
            "sections": {m: {"EA": f"F{i}", "EIy": 40.0, "EIz": 40.0, "GJ": 30.0, "rhoA": 0.8, "rhoIy": 1e-4,
                             "rhoIz": 1e-4} for i, m in enumerate(members)},
            "bodies": {n: ({"at": at, "fixed": True} if n in ("b0", "t0") else {"at": at, "mass": 0.05})
                       for n, at in nodes.items()},
            "beams": {m: {"from": a, "to": b, "section": m, "elements": 1} for m, (a, b) in members.items()},
            "loads": [{"at": f"b{bays}", "force": [0, "-400*t", 0]}], "solve": solve,
            "output": {"every": 0.01, "probes": {"tip_y": {"point": f"b{bays}", "quantity": "displacement",
                                                           "component": "y"}}}}


def latching_boom(names: list[str], segments: int = 50) -> dict:
    """``--scene boom_latch``: a deploying boom — the planar arm of tests/test_sensitivities_events.py swung open by
    its root hinge's spring and latching at 0.8 rad (t = 0.46 s), 60 steps of 0.01 s — made of ``segments`` tubes of
    one element, each its own section: the parameters ``F<2i>`` its EI (EIy and EIz) and ``F<2i+1>`` its ρ (ρA, and
    the rotary inertias with it), 100 at 50 segments; no load (the adjoint through events takes no laws in t). The
    latch-impact response: the tip's position and the root's angle."""
    joints = [f"j{i}" for i in range(1, segments)] + ["tip"]
    bodies = {"base": {"at": [0, 0, 0], "fixed": True},
              **{name: {"at": [(i + 1) / segments, 0, 0], "mass": 0.01, "inertia": [1e-6, 1e-6, 1e-6]}
                 for i, name in enumerate(joints[:-1])},
              "tip": {"at": [1.0, 0, 0], "mass": 0.3, "inertia": [0.01, 0.01, 0.01]}}
    sections = {f"s{i}": {"EA": 1.0e4, "EIy": f"F{2 * i}", "EIz": f"F{2 * i}", "GJ": 10.0, "rhoA": f"F{2 * i + 1}",
                          "rhoIy": f"0.001*F{2 * i + 1}", "rhoIz": f"0.001*F{2 * i + 1}"} for i in range(segments)}
    beams = {f"b{i}": {"from": "base" if i == 0 else joints[i - 1], "to": joints[i], "section": f"s{i}", "elements": 1}
             for i in range(segments)}
    beams["b0"]["start"] = {"hinge": {"axis": [0, 0, 1], "stiffness": 2.0, "damping": 0.05, "rest_angle": 2.0,
                                      "lock_at": 0.8}}
    solve = {"analysis": "transient", "dt": 0.01, "t_end": 0.6, **({"sensitivities": names} if names else {})}
    return {"parameters": {f"F{i}": (20.0 if i % 2 == 0 else 0.5) for i in range(2 * segments)},
            "sections": sections, "bodies": bodies, "beams": beams, "solve": solve,
            "output": {"every": 0.05, "probes": {"tip_y": {"point": "tip", "quantity": "position", "component": "y"},
                                                 "root": {"hinge": "b0.start", "quantity": "angle"}}}}


def lattice_latch(names: list[str], bays: int = 9, *, stiffness: float = 200.0, t_end: float = 0.8,
                  dt: float = 0.005, hub: tuple = (5.0, 0.05), post_rotary: float | None = 0.1,
                  rho_inf: float | None = None) -> dict:
    """``--scene lattice_latch``: a deploying lattice that latches — the 3D truss of benchmarks/lattice.py (aluminium
    tubes, shear-deformable with rotary inertia, rigid massless joints, one element a member), ``bays`` bays (9: 108
    members, 36 joint bodies), its root station welded to a hub (5 kg, inertia 0.05 kg m², the section's centre) that
    turns on a hinge about z at the end of a short stiff post; the hinge's spring (``stiffness``, rest angle 2 rad)
    swings the truss open from rest until it latches at 1 rad (t = 0.693 s at 9 bays), then the
    truss rings on the latched root; no load, no gravity. The parameters: ``F<i>`` the EA of member i (its own
    section), 108 at 9 bays. The latch-impact response: the hinge's torque (the spring's while free, the latch's
    reaction once latched), its largest and smallest value and its end. ``hub``: the hub's mass and inertia (those of
    a root fitting; ``(0, 0)`` a massless hub), ``post_rotary``: the post's rotary inertia per length (``None``: none,
    its twist then has no inertia, which sensitivities through a latch refuse): a massless hub on a post of ρI 1e-3
    gives the light, stiff directions at the root consistent start accelerations that the first step cannot carry
    (docs/initial_state.md, "A step load on light, stiff directions")."""
    from benchmarks import lattice as truss

    b = truss.WIDTH
    members = truss.members(bays)
    sections, parameters = {}, {}
    for i, (name, _, _, kind) in enumerate(members):
        tube = truss.SECTIONS[kind]
        parameters[f"F{i}"] = tube["EA"]
        sections[name] = {"EA": f"F{i}", "EIy": tube["EI"], "EIz": tube["EI"], "GJ": tube["GJ"], "GAy": tube["GA"],
                          "GAz": tube["GA"], "rhoA": tube["rhoA"], "rhoIy": tube["rhoI"], "rhoIz": tube["rhoI"]}
    sections["post"] = {"EA": 1.0e9, "EIy": 1.0e7, "EIz": 1.0e7, "GJ": 1.0e7, "rhoA": 1.0,
                        **({"rhoIy": post_rotary, "rhoIz": post_rotary} if post_rotary else {})}
    bodies = {"base": {"at": [0.0, b / 2, b / 2 - 0.2], "fixed": True},
              "hub": {"at": [0.0, b / 2, b / 2], "mass": hub[0], "inertia": [hub[1]] * 3},
              **{joint: {"at": list(at)} for joint, at in truss.joints(bays).items() if not truss.is_fixed(joint)}}

    def end(joint: str):
        """A joint body, or a point of the hub for the root station's corners."""
        if not truss.is_fixed(joint):
            return joint
        x, y, z = truss.joints(bays)[joint]
        return {"body": "hub", "offset": [x, y - b / 2, z - b / 2]}

    beams = {"post": {"from": "base", "to": "hub", "section": "post", "elements": 1,
                      "end": {"hinge": {"axis": [0, 0, 1], "stiffness": stiffness, "rest_angle": 2.0, "lock_at": 1.0}}},
             **{name: {"from": end(start), "to": end(stop), "section": name, "elements": 1}
                for name, start, stop, _ in members}}
    solve = {"analysis": "transient", "dt": dt, "t_end": t_end, **({"sensitivities": names} if names else {}),
             **({"rho_inf": rho_inf} if rho_inf is not None else {})}
    return {"title": f"a {bays}-bay truss deployed by its root hinge's spring, latching at 1 rad",
            "parameters": parameters, "sections": sections, "bodies": bodies, "beams": beams, "solve": solve,
            "output": {"every": dt, "paraview_every": 0,
                       "probes": {"torque": {"hinge": "post.end", "quantity": "torque"}}}}


def adjoint(data: dict) -> dict:
    """The scene with ``solve.sensitivity_method: adjoint``."""
    return {**data, "solve": {**data["solve"], "sensitivity_method": "adjoint"}}


def run(loaded, per_step: bool, sensitivities_from_python: bool = False) -> tuple[float, float]:
    """(wall time, CPU time of this process) of ``latdyn.run``: on a shared machine the CPU time moves
    less with the other work than the wall time does. ``sensitivities_from_python``: the loop of steps in C on, the
    sensitivities' steps from Python all the same (latdyn.analyses.sensitivities_in_loop and, for the adjoint's forward
    pass, latdyn.analyses.adjoint_in_loop off: the paths before the smooth steps ran in the loop)."""
    from latdyn.analyses import adjoint_in_loop, sensitivities_in_loop

    transient.COMPILED_LOOP = not per_step
    sensitivities_in_loop.SENSITIVITIES_IN_LOOP = not sensitivities_from_python
    adjoint_in_loop.ADJOINT_IN_LOOP = not sensitivities_from_python
    try:
        start, cpu = time.perf_counter(), time.process_time()
        latdyn.run(loaded)
        return time.perf_counter() - start, time.process_time() - cpu
    finally:
        transient.COMPILED_LOOP = True
        sensitivities_in_loop.SENSITIVITIES_IN_LOOP = True
        adjoint_in_loop.ADJOINT_IN_LOOP = True


def in_loop_check(make, counts, folder: str) -> None:
    """``--in-loop-check DIR``: each forward run with k = ``counts`` parameters written twice under DIR, its smooth
    steps' sensitivities in the loop of steps and every step from Python (latdyn/analyses/sensitivities_in_loop.py),
    and each adjoint run twice, its forward pass's smooth steps stored by the loop of steps and every step from Python
    (latdyn/analyses/adjoint_in_loop.py); printed: the sha-256 of sensitivities.csv, probes.csv and summary.json's
    probe_sensitivities and event_sensitivities of each, whether they agree, and the steps taken in the loop."""
    import hashlib
    import json
    from pathlib import Path

    from latdyn.analyses import adjoint_in_loop, sensitivities_in_loop

    def digest(data: bytes) -> str:
        return hashlib.sha256(data).hexdigest()[:16]

    for k, method in [(k, method) for method in ("forward", "adjoint") for k in counts]:
        seen = {}
        for in_loop in (True, False):
            out = Path(folder) / f"{k}-{method}-{'loop' if in_loop else 'python'}"
            sensitivities_in_loop.SENSITIVITIES_IN_LOOP = adjoint_in_loop.ADJOINT_IN_LOOP = in_loop
            data = make([f"F{i}" for i in range(k)])
            try:
                latdyn.run(latdyn.load_scene(adjoint(data) if method == "adjoint" else data), out)
            finally:
                sensitivities_in_loop.SENSITIVITIES_IN_LOOP = adjoint_in_loop.ADJOINT_IN_LOOP = True
            summary = json.loads((out / "summary.json").read_text())
            seen[in_loop] = ([digest((out / name).read_bytes()) for name in ("sensitivities.csv", "probes.csv")]
                             + [digest(json.dumps(summary.get(key), sort_keys=True).encode())
                                for key in ("probe_sensitivities", "event_sensitivities")],
                             summary["sensitivity_steps_in_loop"], summary["steps"])
        same = seen[True][0] == seen[False][0]
        print(f"{method:7s} {k:4d} parameters: sensitivities.csv, probes.csv, probe_sensitivities, event_sensitivities "
              f"{' '.join(seen[True][0])} (in the loop: {seen[True][1]} of {seen[True][2]} steps) / "
              f"{' '.join(seen[False][0])} (from Python: {seen[False][1]}): {'equal' if same else 'DIFFERENT'}")


def parts(make, repeats: int) -> None:
    """``--parts``: the fixed part F of a sensitivity step at the last step's end of a one-parameter run,
    its pieces timed in turn (CPU time of the process, minima over ``10 * repeats`` interleaved calls): the
    whole sensitivity step (``TransientSensitivities.step``, 1 and 101 columns the same call: the run's own
    k); the native evaluation with the elements' inertia tangent and without it; M, C and K scattered on the
    assembler's pattern (``Assembler.exact_matrix_values``: that evaluation included); the step matrix S
    summed on its held pattern (``ExactStepMatrix.values``), loaded and factorised in the storage chosen for
    its pattern — printed with the run's own iteration matrix's, and the run's matrix factorised in that
    storage for comparison —, one or 101 columns solved; the one native call of the step's matrix
    (``ExactStepMatrix.solve_step``: S summed, factorised, the columns formed and solved) and the two of its
    predicted parts and update (``_StepColumns``); the path models with rigid links or guides take
    (``exact_matrices``, SciPy's sum, ``solve_linear``); the exponential's operators R, J; ∂r/∂p."""
    import numpy as np

    from latdyn.assembly.factorization import Factorization, solve_linear
    from latdyn.step.compiled import matrix_pattern

    taken = {}
    step = TransientSensitivities.step

    def kept(self, carried, old, new, *args, **kwargs):
        taken.update(owner=self, call=(carried, old, new, *args), keywords=kwargs)
        return step(self, carried, old, new, *args, **kwargs)

    TransientSensitivities.step = kept
    try:
        run(latdyn.load_scene(make(["F0"])), False, True)   # the per-step path, whose step it takes apart
    finally:
        TransientSensitivities.step = step
    owner, call, keywords = taken["owner"], taken["call"], taken["keywords"]
    state = call[2]
    assembler, n = owner.assembler, owner.model.n_dofs
    increment = 1e-3 * np.random.default_rng(0).standard_normal(n)
    _, tangent = owner._rotation_operators(increment)
    beta_p, gamma_p = 1e5, 1e2
    step_matrix = owner._step_matrix(tangent.slots)
    values = assembler.exact_matrix_values(state)
    summed = step_matrix.values(values, tangent.blocks, beta_p, gamma_p)
    factorization = step_matrix.factorization
    own = Factorization(*matrix_pattern(assembler), n)   # the run's iteration matrix's storage (latdyn/step/compiled.py)
    own_values = np.bincount(own.position(step_matrix.rows, step_matrix.cols), weights=summed, minlength=own.size)

    def solved(k):
        return factorization.solve(np.ones((n, k)))

    def native_step(k):   # S summed, factorised, the k columns formed and solved: one call
        columns = np.ones((n, k))
        return step_matrix.solve_step(values, tangent.blocks, beta_p, gamma_p, columns, columns, columns)

    def before_and_after(k):   # the predicted parts and the update: two calls
        from latdyn.analyses.transient_sensitivities import _StepColumns

        turn, tangent_now = owner._rotation_operators(increment)
        columns = _StepColumns(owner, n, k - 1, (0.002, 0.1, 0.2, 0.6, 0.3), turn, tangent_now)
        carried = np.ones((n, k - 1))
        columns.predict(increment, increment, increment, carried, carried, carried, carried)
        return columns.update(np.ones((n, k)), beta_p, gamma_p)

    def scipy_path(k):
        M, C, K = owner._matrices(state)
        J = tangent.matrix if hasattr(K, "tocsr") else tangent.matrix.toarray()
        return solve_linear(beta_p * M + gamma_p * C + K @ J, np.ones((n, k)))

    def run_matrix_factorised(k):
        own.values[:] = own_values
        own._library.latdyn_factor(ctypes.byref(own.structure), own.values.ctypes.data, own.pivots.ctypes.data)

    native = assembler.native(True)
    pieces = {"the whole sensitivity step (TransientSensitivities.step)": lambda k: step(owner, *call, **keywords),
              "native evaluation with the elements' inertia tangent":
              lambda k: native.evaluate(state, True, 1.0, True, True),
              "native evaluation of M, C, K without it": lambda k: native.evaluate(state, True, 1.0, True, False),
              "M, C, K on the pattern (exact_matrix_values, evaluation incl.)":
              lambda k: assembler.exact_matrix_values(state),
              "S summed on its held pattern (ExactStepMatrix.values)":
              lambda k: step_matrix.values(values, tangent.blocks, beta_p, gamma_p),
              "S summed, loaded and factorised (ExactStepMatrix.factor)":
              lambda k: step_matrix.factor(values, tangent.blocks, beta_p, gamma_p),
              "the run's matrix factorised in its storage (latdyn_factor)": run_matrix_factorised,
              "S's columns solved": solved,
              "S summed, factorised, columns formed and solved (solve_step)": native_step,
              "predicted parts and update (with R, J: _StepColumns)": before_and_after,
              "the path with links: exact_matrices + SciPy sum + solve": scipy_path,
              "the exponential's operators R, J": lambda k: owner._rotation_operators(increment),
              "dr/dp (residual_derivatives, 1 parameter)": lambda k: owner.residual_derivatives(state, 1.0, True)}
    best = {name: {1: np.inf, 101: np.inf} for name in pieces}
    for _ in range(10 * repeats):
        for name, piece in pieces.items():
            for k in (1, 101):
                began = time.process_time()
                piece(k)
                best[name][k] = min(best[name][k], time.process_time() - began)
    factorization.factor(summed)
    print(f"F's pieces, n = {n} coordinates; load average (1 min): {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(f"  S: {factorization.kind} storage, kl = ku = {factorization.kl}/{factorization.ku}, {len(summed)} entries; "
          f"the run's iteration matrix: {own.kind}, {own.kl}/{own.ku}, {len(own.rows)} entries")
    for name, measured in best.items():
        print(f"  {name:62s} 1 column {measured[1] * 1e3:6.3f} ms, 101 columns {measured[101] * 1e3:6.3f} ms")
    print(f"  the two step matrices' solutions differ by {np.max(np.abs(solved(101) - scipy_path(101))):.1e}")


#: ``--phases``: the pieces of a forward run timed inside the run, (label, owner, method, indent): each wrapped to add
#: its CPU time to the label's total (inclusive of the pieces below it; "rest" lines are the differences)
PHASES = (("the run's own step (Newton, every step from Python)", "TimeLoop", "_python_step", 1),
          ("the accepted step's bookkeeping (events, work, rows due; sensitivities apart)", "TimeLoop", "_accept", 1),
          ("the sensitivity step (TransientSensitivities.step)", "TransientSensitivities", "step", 2),
          ("step_columns: the step's derivative before δh", "TransientSensitivities", "step_columns", 3),
          ("R, J (_rotation_operators)", "TransientSensitivities", "_rotation_operators", 4),
          ("predicted parts (one native call)", "_StepColumns", "predict", 4),
          ("M, C, exact K on the pattern (exact_matrix_values)", "Assembler", "exact_matrix_values", 4),
          ("native evaluation with the inertia tangent", "NativeModel", "evaluate", 5),
          ("joint bodies' inertia stiffness (kernel)", "Assembler", "joint_body_inertia_stiffness", 5),
          ("dr/dp (residual_derivatives)", "TransientSensitivities", "residual_derivatives", 4),
          ("sections' dr/dp (kernels by the section values, contracted, scattered)", "ParameterDerivatives",
           "_section_forces", 5),
          ("S summed, factorised, k + 1 columns solved (one native call)", "ExactStepMatrix", "solve_step", 4),
          ("update (one native call)", "_StepColumns", "update", 4),
          ("the next step size's derivative (resized)", "TransientSensitivities", "resized", 2),
          ("after the events (after_events: renumbering, restarts)", "TransientSensitivities", "after_events", 2),
          ("the rows' sensitivities (record)", "TransientSensitivities", "record", 1),
          ("set-up: derivative laws, probes (TransientSensitivities.__init__)", "TransientSensitivities", "__init__", 1),
          ("the start's derivative (start)", "TransientSensitivities", "start", 1),
          ("sensitivities.csv and summary (finish)", "TransientSensitivities", "finish", 1))


def phases(make, k: int, repeats: int) -> None:
    """``--phases``: one forward run with ``k`` parameters (kernels compiled before, the loop of steps in C off as a
    sensitivity run has it), its pieces (:data:`PHASES`) timed inside the run by wrapping each method to add the
    process's CPU time it takes, per run and per accepted step; the minimum over ``repeats`` runs of each piece's
    per-run total, and of the whole run's. Printed with the run without sensitivities (loop of steps in C) for
    scale. The wrappers add ≈ 1 µs a call."""
    import functools

    from latdyn.analyses import sensitivities, step_matrix, transient_sensitivities
    from latdyn.assembly import assembler, native_model
    from latdyn.timeloop import loop

    owners = {"TimeLoop": loop.TimeLoop, "TransientSensitivities": transient_sensitivities.TransientSensitivities,
              "_StepColumns": transient_sensitivities._StepColumns, "Assembler": assembler.Assembler,
              "NativeModel": native_model.NativeModel, "ParameterDerivatives": sensitivities.ParameterDerivatives,
              "ExactStepMatrix": step_matrix.ExactStepMatrix}
    totals, calls, inside = {}, {}, {"sensitivity step": False}

    def wrapped(label, method):
        @functools.wraps(method)
        def timed(*args, **kwargs):
            if label.startswith("native evaluation") and not inside["sensitivity step"]:
                return method(*args, **kwargs)   # the run's own evaluations are inside its step's figure
            began = time.process_time()
            try:
                return method(*args, **kwargs)
            finally:
                totals[label] = totals.get(label, 0.0) + time.process_time() - began
                calls[label] = calls.get(label, 0) + 1
        return timed

    def marking(method):
        @functools.wraps(method)
        def marked(*args, **kwargs):
            inside["sensitivity step"] = True
            try:
                return method(*args, **kwargs)
            finally:
                inside["sensitivity step"] = False
        return marked

    kept = [(owners[owner], name, getattr(owners[owner], name)) for _, owner, name, _ in PHASES]
    for (label, owner, name, _), (_, _, method) in zip(PHASES, kept):
        setattr(owners[owner], name, wrapped(label, method))
    transient_sensitivities.TransientSensitivities.step = marking(transient_sensitivities.TransientSensitivities.step)
    try:
        loaded = latdyn.load_scene(make([f"F{i}" for i in range(k)]))
        without = latdyn.load_scene(make([]))
        run(loaded, False, True), run(without, False)   # the per-step path's pieces (latdyn.analyses.sensitivities_in_loop off)
        best: dict[str, float] = {}
        whole, plain, steps = [], [], 0
        for _ in range(repeats):
            totals.clear(), calls.clear()
            whole.append(run(loaded, False, True)[1])
            plain.append(run(without, False)[1])
            steps = calls.get(PHASES[2][0], 1)
            for label, value in totals.items():
                best[label] = min(best.get(label, float("inf")), value)
    finally:
        for owner, name, method in kept:   # the methods as they were (the marked step's among them)
            setattr(owner, name, method)
    print(f"{k} parameters, {steps} accepted steps; CPU minima of {repeats} runs; load average (1 min): "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(f"  the run without sensitivities (loop of steps in C) {min(plain) * 1e3:7.2f} ms, "
          f"{min(plain) / steps * 1e3:6.3f} ms a step")
    print(f"  the forward run                                    {min(whole) * 1e3:7.2f} ms, "
          f"{min(whole) / steps * 1e3:6.3f} ms a step, {min(whole) / min(plain):4.2f}x")
    # the bookkeeping's figure without the sensitivity pieces the loop calls inside it
    inner = [label for label, _, _, indent in PHASES if indent == 2]
    listed = 0.0
    for label, _, _, indent in PHASES:
        value = best.get(label, 0.0) - (sum(best.get(i, 0.0) for i in inner) if label == PHASES[1][0] else 0.0)
        listed += value if indent == 1 else 0.0
        print(f"  {'  ' * indent}{label:{78 - 2 * indent}s} {value * 1e3:7.2f} ms a run, "
              f"{value / steps * 1e3:6.3f} ms a step")
    rest = min(whole) - listed - sum(best.get(i, 0.0) for i in inner)
    print(f"    {'the rest: the run set up, the loop, the writers (the run without pays most of it)':74s} "
          f"{rest * 1e3:7.2f} ms a run, {rest / steps * 1e3:6.3f} ms a step")
    per_step = run(without, True)[1]
    print(f"  the run without, every step from Python, once: {per_step * 1e3:.2f} ms")


def reverse_parts(make, k: int, repeats: int) -> None:
    """``--reverse-parts K``: the pieces of one step of the adjoint's reverse pass
    (latdyn/analyses/adjoint_sensitivities.py ``AdjointSensitivities.reverse``) at the last stored state of
    a run with K parameters, timed in turn (minima over ``10 * repeats`` interleaved calls, process CPU
    time): the exact M, C, K (the native evaluation with the elements' inertia tangent, scattered), the
    step matrix summed and factorised on its held pattern, the transposed solve of the output columns,
    −(∂r/∂p)ᵀw for the K parameters (:meth:`~AdjointSensitivities.residual_transposed_product`), Kᵀw and
    Cᵀw, and the exponential's operators R, J with their transposes applied."""
    import numpy as np

    from latdyn.analyses.adjoint_sensitivities import AdjointSensitivities, _transposed_rotations

    taken = {}
    reverse = AdjointSensitivities.reverse

    def kept(self, carried, outputs):
        taken["owner"], taken["carried"], taken["m"] = self, carried, len(outputs)
        return reverse(self, carried, outputs)

    AdjointSensitivities.reverse = kept
    try:
        run(latdyn.load_scene(adjoint(make([f"F{i}" for i in range(k)]))), False)
    finally:
        AdjointSensitivities.reverse = reverse
    owner, carried, m = taken["owner"], taken["carried"], taken["m"]
    entry = carried["trajectory"][-1]
    state, h = entry["state"], entry["h"]
    assembler, n = owner.assembler, owner.model.n_dofs
    p = owner.params
    beta_p, gamma_p = (1 - p.alpha_m) / (h * h * p.beta * (1 - p.alpha_f)), p.gamma / (h * p.beta)
    increment = 1e-3 * np.random.default_rng(0).standard_normal(n)
    turn, tangent = owner._rotation_operators(increment)
    w = np.random.default_rng(1).standard_normal((n, m))
    values = assembler.exact_matrix_values(state)
    step_matrix = owner._step_matrix(tangent.slots)
    factors = step_matrix.factor(values, tangent.blocks, beta_p, gamma_p)

    def rotations():
        turn, tangent = owner._rotation_operators(increment)
        tangent_t = _transposed_rotations(owner, tangent)
        return _transposed_rotations(owner, turn)(tangent_t(tangent_t(w)))

    pieces = {"exact M, C, K (evaluation with the inertia tangent, scattered)":
              lambda: assembler.exact_matrix_values(state),
              "step matrix summed and factorised on its held pattern":
              lambda: step_matrix.factor(values, tangent.blocks, beta_p, gamma_p),
              f"transposed solve of the {m} output columns": lambda: factors.solve_transposed(w),
              f"-(dr/dp)^T w for {k} parameters": lambda: owner.residual_transposed_product(state, w),
              "K^T w and C^T w": lambda: (step_matrix.stiffness.T @ w, step_matrix.damping.T @ w),
              "R, J and their transposes applied": rotations}
    best = {name: np.inf for name in pieces}
    for _ in range(10 * repeats):
        for name, piece in pieces.items():
            began = time.process_time()
            piece()
            best[name] = min(best[name], time.process_time() - began)
    print(f"a reverse step's pieces, n = {n} coordinates, {m} output columns, {k} parameters; "
          f"load average (1 min): {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    for name, measured in best.items():
        print(f"  {name:66s} {measured * 1e3:7.3f} ms")


def richardson(make, name: str) -> None:
    """``--richardson NAME``: the adjoint's derivatives by ``NAME`` (every probe's end, max and min, and each event's
    time) against central differences of whole runs at p ± h and p ± h/2 (h = 1e-4 p) extrapolated,
    (4 D(h/2) − D(h))/3; the reference runs ask for the adjoint by ``NAME`` too, so that their steps land on the
    events as the differentiated run's. Every run with ``solve.tol: 1e-12``: the differences of runs converged to the
    default 1e-8 carry its noise divided by h (on the deploying lattice of 2 bays 4e-5 of the probe's largest, 4e-7 at
    1e-12, where plain central differences at h = 4e-4 p agree to 7e-8: the rest is noise too). Printed: each
    output's error relative to the probe's largest extrapolated derivative over the rows (and to its own value), the
    events' relative to their own."""
    import numpy as np

    data = make([name])
    p0 = float(data["parameters"][name])

    def run_at(value):
        changed = adjoint(make([name]))
        changed["parameters"] = {**changed["parameters"], name: value}
        changed["solve"] = {**changed["solve"], "tol": 1e-12}
        return latdyn.run(latdyn.load_scene(changed))

    exact = run_at(p0)
    central, times = [], []
    for step in (1e-4 * p0, 0.5e-4 * p0):
        up, down = run_at(p0 + step), run_at(p0 - step)
        if [e["kind"] for e in up.summary["events"]] != [e["kind"] for e in down.summary["events"]]:
            raise SystemExit(f"the events differ between {name} ± {step:g}")
        central.append({probe: (up.probes[probe] - down.probes[probe]) / (2 * step) for probe in up.probes})
        times.append([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"], down.summary["events"])])
    print(f"Richardson check of the adjoint by {name} = {p0:g} (h = 1e-4 and 5e-5 relative); "
          f"load average (1 min): {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    for probe, by in exact.summary["probe_sensitivities"].items():
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        values = exact.probes[probe]
        for which, row in (("end", len(values) - 1), ("max", int(np.argmax(values))), ("min", int(np.argmin(values)))):
            error = abs(by[which][name] - expected[row])
            print(f"  {probe} {which:3s} (t = {exact.t[row]:.4f}): adjoint {by[which][name]: .10e}, differences "
                  f"{expected[row]: .10e}: {error / np.abs(expected).max():.1e} of the probe's largest, "
                  f"{error / abs(expected[row]):.1e} of its own")
    for event, coarse, fine in zip(exact.summary["event_sensitivities"], *times):
        expected = (4 * fine - coarse) / 3
        print(f"  {event['joint']} {event['kind']} at t = {event['t']:.6f}: "
              f"dt/d{name} adjoint {event['dt'][name]: .6e}, differences {expected: .6e}: "
              f"{abs(event['dt'][name] - expected) / abs(expected):.1e} of its own")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scene", choices=("cantilever", "lattice", "lattice1000", "boom_latch", "lattice_latch"),
                        default="cantilever",
                        help="the cantilever with 100 load parameters, the lattice with 100 section parameters, "
                             "the lattice of 1000 members with 1000, or a deploying boom of 50 sections that "
                             "latches, with 100, or a 3D truss of 9 bays (108 members) deployed on a root hinge "
                             "that latches, with 100 of its members' EA")
    parser.add_argument("--cases", default=None, help="comma-separated case names to run (default: all)")
    parser.add_argument("--parts", action="store_true", help="time the pieces of the fixed part F of a step instead")
    parser.add_argument("--phases", type=int, default=None, metavar="K",
                        help="time the pieces of a forward run with K parameters inside the run instead")
    parser.add_argument("--reverse-parts", type=int, default=None, metavar="K",
                        help="time the pieces of a step of the adjoint's reverse pass with K parameters instead")
    parser.add_argument("--in-loop-check", default=None, metavar="DIR",
                        help="write each forward run with its smooth steps' sensitivities in the loop of steps and "
                             "from Python under DIR and compare them by sha-256 instead")
    parser.add_argument("--richardson", default=None, metavar="NAME",
                        help="check the adjoint's derivatives by NAME against Richardson-extrapolated central "
                             "differences of whole runs instead")
    args = parser.parse_args()
    make = {"cantilever": scene, "lattice": lattice, "lattice1000": lambda names: lattice(names, bays=250),
            "boom_latch": latching_boom, "lattice_latch": lattice_latch}[args.scene]
    if args.parts:
        parts(make, args.repeats)
        return
    if args.phases is not None:
        phases(make, args.phases, args.repeats)
        return
    if args.reverse_parts is not None:
        reverse_parts(make, args.reverse_parts, args.repeats)
        return
    if args.richardson is not None:
        richardson(make, args.richardson)
        return
    counts = (1, 10, 100, 1000) if args.scene == "lattice1000" else (1, 10, 100)
    if args.in_loop_check is not None:
        in_loop_check(make, counts if args.scene != "boom_latch" else (10, 100), args.in_loop_check)
        return
    cases = {"0 (loop in C)": (0, False, False), "0 (per step)": (0, True, False)}
    cases.update({f"{k} forward": (k, False, False) for k in counts})
    cases.update({f"{k} forward (Python steps)": (k, False, False) for k in counts})
    cases.update({f"{k} adjoint": (k, False, True) for k in counts})
    cases.update({f"{k} adjoint (Python steps)": (k, False, True) for k in counts})
    if args.cases:
        cases = {name: case for name, case in cases.items() if name in args.cases.split(",")}
    loaded = {name: latdyn.load_scene((adjoint if by_adjoint else dict)(make([f"F{i}" for i in range(k)])))
              for name, (k, _, by_adjoint) in cases.items()}
    for name, (_, per_step, _) in cases.items():
        run(loaded[name], per_step, "Python steps" in name)   # compile the kernels and laws once
    times: dict[str, list[float]] = {name: [] for name in cases}
    cpu: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(args.repeats):
        for name, (_, per_step, _) in cases.items():
            wall, used = run(loaded[name], per_step, "Python steps" in name)
            times[name].append(wall)
            cpu[name].append(used)
    print(f"load average (1 min): {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    base = min(times.get("0 (loop in C)", [float("nan")]))
    base_cpu = min(cpu.get("0 (loop in C)", [float("nan")]))
    for name, measured in times.items():
        print(f"{name:26s} parameters: wall min {min(measured) * 1e3:8.1f} ms, "
              f"median {statistics.median(measured) * 1e3:8.1f} ms, {min(measured) / base:5.2f}x; "
              f"CPU min {min(cpu[name]) * 1e3:8.1f} ms, median {statistics.median(cpu[name]) * 1e3:8.1f} ms, "
              f"{min(cpu[name]) / base_cpu:5.2f}x the run without (minima)")


if __name__ == "__main__":
    main()
