"""Where a law of the scene jumps in time: the steps land there.

A law in t may jump: ``Heaviside(t - 0.01)``, ``sign(t - 0.2)``, ``Piecewise((0, t < 0.5), (3, True))``
in a load component, a hinge's or guide's law, a cable's rest length, a prescribed motion or a
continuous controller's output. A step that crosses such a jump integrates a law that is not smooth
inside it: its error is O(h · jump) in the rates, and it does not fall with the step in a way the
run can see — where the jump falls inside the step changes with every event before it and with
every adaptive step, and the error estimate (built on smooth motion) does not reject it. Found by
the whole-run fuzzer's step check (``benchmarks/fuzz_runs.py --step-check``): a hub driven by
``18.18*Heaviside(t - 0.01)`` beside a cable that went taut at t = 1e-5 (the grid moved off the jump)
ended "solved" with its momentum 1.2 % off at dt, dt/2 and dt/4 alike (error_tol 1e-4).

:func:`jump_times` finds the instants in (0, t_end] where a law whose text names ``Heaviside``,
``sign`` or ``Piecewise`` is not continuous in t, two ways, and takes every jump either finds: on its
compiled values, every interval of a fine sampling whose change is more than :data:`CONTINUOUS` of the
values is halved down to round-off, and a change that stays there is a jump (a ``Piecewise`` that joins
continuously, as the spin-up's ramp, is none); and at the zeros in t of its jumps' arguments in its
text (SymPy parses the text of such a law only), where its values before and after differ — jumps
close together, a pulse inside one interval of the sampling, a jump on a larger oscillation. A hinge
or guide law is taken at fixed generic θ, θ̇; a law that names inputs at generic values of them too
(:func:`input_timed_jump_key`: a jump whose time an input gives is refused where inputs change). A continuous controller's output is searched on its parsed expression (the zeros of
its jumps' arguments in t). The
time loop puts them on its grid (:class:`latdyn.timeloop.control.StepControl` ``jumps``): the step
that would cross one ends :data:`JUMP_SIDE` · dt before it, so that it integrates the law as it was
(the value *at* the jump — ``Heaviside(0) = 1/2``, ``Piecewise``'s first true branch — belongs to
neither side); there the integrator restarts from the accelerations of the law as it is after the
jump, evaluated :data:`JUMP_SIDE` · dt after it (``TimeLoop.restart``, as after an input changed
from outside, docs/stepping.md), and the run goes on from that time. The 2 · JUMP_SIDE · dt skipped
moves nothing (the state is held across it); a sampled controller's sample due at the jump's instant
is taken there, after it (``TimeLoop._after_accepted``), before the one restart. A jump at t = 0 is
started from the law just after it (:func:`starts_on_a_jump`); one at t_end (within 1e-12 · t_end)
ends the run :data:`JUMP_SIDE` · dt before it. Each step then integrates a smooth law: the run
converges at its method's order again (a rigid arm under ``2*Heaviside(t - 0.013)``, exact
θ = τ(t − t₀)²/2J: tests/test_law_jumps.py).

What a search of one law finds (its values' jumps, its rate's kinks, its acceleration's jumps) is a
function of the law's text (its parameters substituted), of which kind of law it is and of t_end alone:
it is kept in the laws' cache beside the compiled law (latdyn.scene.expressions, :func:`_searched`), so
that a process whose laws were searched before reads the instants back instead of sweeping and halving
again (≈ 50 evaluations of 4 098 samples a search: 13–14 ms of CPU at the spin-up's start,
docs/performance.md "Eleventh pass"). A law that names inputs is searched every time (its values follow
the inputs' current values, as its compiled law is never cached). A run's start searches once
(:func:`searched_jumps`): the refusal of a prescribed position that jumps, the instants the steps land
on and the restarts' prescribed accelerations (:func:`acceleration_only_jumps`) are all taken from that
one search.

Jumps in ``theta``, ``s`` or their rates are the state's (stops and latches are events of their own)
and are not searched for here; a table of t is continuous (its kinks are not jumps); a sampled
controller's output jumps at its samples, which restart the run already (latdyn.timeloop.sampling).
"""
from __future__ import annotations

import json
import re
from typing import NamedTuple

import numpy as np

#: words of a law whose text may jump in t; a law without any of them is not parsed (no SymPy)
_JUMPING = re.compile(r"\b(Heaviside|sign|Piecewise)\b")
#: a law whose text does not name t does not jump in t
_NAMES_T = re.compile(r"\bt\b")
#: samples over (0, t_end) that bracket a law's jumps (a controller's: its jumps' arguments' sign
#: changes), each then halved down to round-off
SAMPLES = 4096
#: the step that reaches a jump ends this fraction of dt before it, and the run restarts this fraction
#: of dt after it (each side's law evaluated on its own side of the jump)
JUMP_SIDE = 1e-9
#: a change left across the halved interval (a controller's: across 1e-12 t_end) smaller than this,
#: relative to 1 + the values' size, is no jump (a kink, a steep smooth stretch)
CONTINUOUS = 1e-6


class LawJumps(NamedTuple):
    """What a run's start finds searching the laws of its scene once, each a list of (key, time):
    ``values``, the jumps of a law's value (:func:`law_jumps`); ``rates``, the kinks of a prescribed
    position (:func:`prescribed_rate_kinks`); ``accelerations``, the jumps of a prescribed position's
    acceleration (:func:`prescribed_acceleration_jumps`)."""

    values: list
    rates: list
    accelerations: list


def searched_jumps(scene, t_end: float) -> LawJumps:
    """Every search of ``scene``'s laws over (0, ``t_end``], once for a run's start, which asks it three times
    (:func:`prescribed_position_jump`, :func:`jump_times`, :func:`acceleration_only_jumps`)."""
    return LawJumps(law_jumps(scene, t_end), prescribed_rate_kinks(scene, t_end),
                    prescribed_acceleration_jumps(scene, t_end))


def law_jumps(scene, t_end: float) -> list[tuple[str, float]]:
    """(key, time) of every jump in t of a law of ``scene``'s value (:func:`_jumps`)."""
    return list(_jumps(scene, t_end))


def jump_times(scene, t_end: float, found: LawJumps | None = None) -> np.ndarray:
    """The sorted instants in (0, ``t_end``] where a law of ``scene`` jumps in t (module docstring);
    empty where none does (``found``: :func:`searched_jumps` of the scene, where searched already). A jump
    within 1e-12 · t_end of t_end is at t_end (the last step lands :data:`JUMP_SIDE` · dt before it); jumps
    within 1e-12 · t_end of each other are one."""
    found = searched_jumps(scene, t_end) if found is None else found
    times = sorted(_in_run(t, t_end) for _, t in found.values + found.accelerations + found.rates
                   if _in_run(t, t_end) is not None)
    merged: list[float] = []
    for t in times:
        if not merged or t - merged[-1] > 1e-12 * t_end:
            merged.append(t)
        elif t == t_end:
            merged[-1] = t_end
    return np.array(merged, dtype=float)


def jumping_key(scene, t_end: float) -> str | None:
    """The key of the first law of ``scene`` that jumps in (0, ``t_end``], else None (for refusals)."""
    return next((key for key, t in _jumps(scene, t_end) if _in_run(t, t_end) is not None), None)


#: the keys of the laws that prescribe a position (a hinge's angle, a guide's slide, a body's motion)
_PRESCRIBED_POSITION = re.compile(r"(\.hinge\.angle|\.guide\.position|\.motion\.translation\[\d\]|"
                                  r"\.motion\.rotation\.angle)$")


def prescribed_position_jump(scene, t_end: float, found: LawJumps | None = None) -> tuple[str, float] | None:
    """(key, time) of the first jump in t, in (0, ``t_end``], of a law that prescribes a position (a hinge's
    ``angle``, a guide's ``position``, a body's ``motion``), else None. Such a jump is no motion: it
    would move the joint (and what it carries) by a finite amount in no time, at an infinite rate, and
    the run restarted from the new position as if it had always been there (a rigid link turned 0.5 rad
    in no time, `solved`; a flexible arm so moved ended with 8.3 J it had received from nowhere). A jump
    of the *rate* (a kink, ``Piecewise((0, t < 0.5), (t - 0.5, True))``) is not a jump of the law's value
    and is not searched for here (``found``: :func:`searched_jumps` of the scene, where searched already)."""
    for key, t in (_jumps(scene, t_end) if found is None else found.values):
        if _PRESCRIBED_POSITION.search(key) and _in_run(t, t_end) is not None:
            return key, float(t)
    return None


def prescribed_rate_kinks(scene, t_end: float) -> list[tuple[str, float]]:
    """(key, time) of the instants in (0, ``t_end``] where the *rate* of a law that prescribes a position
    jumps (a kink: ``Piecewise((0, t < 0.5), (2*(t - 0.5), True))``, a table's inner node). Such a drive
    applies an impulse to the free parts it carries: the steps land on the kink (:func:`jump_times`) and
    the restart after it gives the free rates the jump that impulse makes
    (latdyn.timeloop.impulse.prescribed_velocity_jump). Before, a step across the kink took the prescribed
    coordinate's new rate while the free joints it carries kept their relative rates, so those parts were
    carried along rigidly (a crank kinked to 2 rad/s carrying a free rod: the rod turned with it, 5.33 J
    of kinetic energy, where the impulse gives the hinge −5 rad/s and 1.17 J in all)."""
    found = []
    for key, law in prescribed_positions(scene):
        rate = getattr(law, "rate", None)
        if rate is None or getattr(law, "is_constant", False):
            continue
        found.extend((key, float(time)) for time in _searched(
            "rates", law, t_end, lambda rate=rate: _jumps_of_values(
                lambda t: np.asarray(rate(np.asarray(t, float)), float), t_end))
                     if 0.0 < time <= t_end * (1 + 1e-12))
    return found


def acceleration_only_jumps(scene, t_end: float, found: LawJumps | None = None) -> np.ndarray:
    """The instants of :func:`prescribed_acceleration_jumps` where nothing else jumps (no law's value,
    no prescribed rate: :func:`jump_times`' other sources, within 1e-12 · t_end): there the restart
    changes the free accelerations by the response to the change of the prescribed ones alone
    (latdyn.timeloop.impulse.prescribed_acceleration_jump) instead of solving them again (``found``:
    :func:`searched_jumps` of the scene, where searched already)."""
    found = searched_jumps(scene, t_end) if found is None else found
    others = [t for _, t in found.values + found.rates]
    return np.array(sorted({float(t) for _, t in found.accelerations
                            if all(abs(t - u) > 1e-12 * t_end for u in others)}), dtype=float)


def prescribed_motion_jump_key(scene, t_end: float) -> tuple[str, float] | None:
    """(key, time) of the first kink (:func:`prescribed_rate_kinks`) or jump of the acceleration
    (:func:`prescribed_acceleration_jumps`) of a prescribed motion, where the run lands and restarts (for
    the refusals of what does not differentiate that restart), else None."""
    found = sorted(prescribed_rate_kinks(scene, t_end) + prescribed_acceleration_jumps(scene, t_end),
                   key=lambda pair: pair[1])
    return found[0] if found else None


def prescribed_acceleration_jumps(scene, t_end: float) -> list[tuple[str, float]]:
    """(key, time) of the instants in (0, ``t_end``] where the *acceleration* of a law that prescribes a
    position jumps while its value and rate do not (the ends of a ramp of constant acceleration,
    ``Piecewise((0, t < 0.5), (100*(t - 0.5)**2, t < 0.51), (0.01 + 2*(t - 0.51), True))``), for a law whose
    text may jump (:func:`_values_in_time`). The prescribed acceleration is a load on the parts the drive
    carries: a step that ends on such an instant took the law's acceleration after it (``Piecewise``'s
    branch there) for its whole end, and one that crosses it integrates a law that is not smooth inside
    it; the steps land on these instants and restart after them as at a jump of a load (:func:`jump_times`).
    Landed on, the drive's work ½(r_n + r_{n+1}) Δq (latdyn.timeloop.progress.drive_work) closes the
    energy balance to the step's order; not landed on, the crank's 10 ms ramp at dt = 0.001 counted
    0.11 J too little of 1.18 J (the reaction of the ramp's acceleration missing from the step ending
    at its end, which moved the crank 2 mrad) and the 1 ms ramp ended falsely ``unbounded``."""
    found = []
    for key, law in prescribed_positions(scene):
        accel = getattr(law, "accel", None)
        if accel is None or _values_in_time(law) is None:
            continue
        found.extend((key, time) for time in _searched(
            "accelerations", law, t_end, lambda accel=accel: _jumps_of_values(
                lambda t: np.asarray(accel(np.asarray(t, float)), float), t_end)))
    return found


def prescribed_positions(scene):
    """(key, law) of every law of ``scene`` that prescribes a position (:func:`prescribed_position_jump`)."""
    return [(key, law) for key, law in _laws(scene)
            if law is not None and not isinstance(law, (int, float)) and _PRESCRIBED_POSITION.search(key)]


def starts_on_a_jump(scene, side: float) -> bool:
    """Whether a law of ``scene`` jumps at t = 0 (its value there is not its value ``side`` after:
    ``2*Heaviside(t)`` is 1 at 0, ``Piecewise((0, t <= 0), (2, True))`` 0): the run then starts from
    the accelerations of the law as it is just after 0 (``TimeLoop._start``)."""
    for _, law in _laws(scene):
        if hasattr(law, "output_text"):
            found = _controller_expression(law)
            if found is not None and _differs(_generic_function(*found), 0.0, side):
                return True
            continue
        values = _values_in_time(law)
        if values is not None and _differs(values, 0.0, side):
            return True
    return False


def _in_run(t: float, t_end: float) -> float | None:
    """``t`` as a jump of a run to ``t_end``: t_end for one within 1e-12 · t_end of it, None outside (0, t_end]."""
    if t_end * (1 - 1e-12) <= t <= t_end:
        return t_end
    return t if 0.0 < t < t_end else None


def _differs(f, a: float, b: float) -> bool:
    """Whether ``f`` at ``a`` and at ``b`` differ by more than :data:`CONTINUOUS` of their size."""
    with np.errstate(all="ignore"):
        fa, fb = (float(np.asarray(f(np.array([x], float)), float).ravel()[0]) for x in (a, b))
    if not (np.isfinite(fa) and np.isfinite(fb)):
        return False
    return abs(fb - fa) > CONTINUOUS * (1.0 + abs(fa) + abs(fb))


def _jumps(scene, t_end: float):
    """(key, time) of every jump in t of a law of ``scene``: for a compiled law, the jumps its values
    show (:func:`_jumps_of_values`) and the zeros of its jumps' arguments in its text
    (:func:`_zeros_of_jumps`) where its values change across them; a controller's, on its parsed
    expression."""
    side = 1e-12 * max(t_end, 1.0)
    searched: dict = {}
    for key, law in _laws(scene):
        if hasattr(law, "output_text"):     # a controller: its parsed expression (SymPy is there already)
            found = _controller_expression(law)
            if found is not None:
                expr, t = found
                for time in _zeros_of_jumps(expr, t, t_end):
                    if _jumps_at(expr, t, time, side):
                        yield key, time
            continue
        values = _values_in_time(law)
        if values is None:
            continue
        same = (law.source, hasattr(law, "d_theta"))   # laws of one text jump alike: searched once a scene
        if same not in searched:
            searched[same] = _searched("values", law, t_end,
                                       lambda law=law, values=values: _law_jumps(law, values, t_end, side))
        yield from ((key, time) for time in searched[same])


#: what a search depends on beside the law and t_end: this module's source (the search itself), NumPy's
#: version (the law's values), :data:`SAMPLES` and :data:`CONTINUOUS` (read at the search: a test may set them)
_SEARCH: list[str] = []


def _searched(search: str, law, t_end: float, find) -> list[float]:
    """The times ``find()`` gives, the ``search`` (``"values"``, ``"rates"`` or ``"accelerations"``) of ``law``
    over (0, ``t_end``]: read from the laws' cache where an earlier process searched the same (the law's text,
    its kind of law, the search, t_end and the search's own code: :data:`_SEARCH`), else found and kept there.
    A law that names inputs is searched every time (its values follow the inputs' current values)."""
    if getattr(law, "input_names", None):
        return find()
    from latdyn.scene import expressions as cache

    if not _SEARCH:
        from pathlib import Path

        from latdyn.native import source_digest

        _SEARCH.append(source_digest(Path(__file__).read_bytes(), np.__version__))
    source = (f"jump times 1:{_SEARCH[0]}:{SAMPLES!r}:{CONTINUOUS!r}:{search}:{type(law).__name__}:{float(t_end)!r}:"
              f"{json.dumps(law.source)}")
    entry = cache.cached_entry("jumps", source)
    if entry is not None and isinstance(entry.get("times"), list):
        try:
            return [float(t) for t in entry["times"]]
        except (TypeError, ValueError):   # an entry not written here: searched again, and written over
            pass
    times = [float(t) for t in find()]
    cache.keep_entry("jumps", source, {"times": times}, {}, [])
    return times


def _law_jumps(law, values, t_end: float, side: float) -> list[float]:
    """The times a compiled law (``values``: it as a function of t) jumps: those its values show
    (:func:`_jumps_of_values`) and the zeros of its jumps' arguments in its text where its values, or a
    law naming inputs its values at generic inputs, change across them."""
    times = _jumps_of_values(values, t_end)
    arguments = _jump_arguments(law)
    if arguments is None:
        return times
    generic = _generic_values_in_time(law, arguments)
    for time in _zeros_in_time(arguments["arguments"], t_end):
        # a law naming inputs: its jump where the inputs' generic values show it too (an input
        # that is 0 at the start, 2*F*Heaviside(t - 0.013), may be set later)
        if _differs(values, time - side, time + side) or \
                (generic is not None and _differs(generic, time - side, time + side)):
            times.append(time)
    return times


def _law_expression(law):
    """(SymPy expression, its t symbol, its input symbols) of a compiled law (SymPy parses its text:
    only for a law whose text names a jump in t), else None."""
    try:
        found = law.expressions
        if found is None:
            return None
        symbols, expressions = found
        t = symbols[2] if hasattr(law, "d_theta") else symbols
        names = set(getattr(law, "input_names", None) or ())
        inputs = [s for s in expressions[0].free_symbols if s.name in names]
        return expressions[0], t, inputs
    except Exception:   # a text SymPy cannot give back: the values' search alone
        return None


def _jump_arguments(law) -> dict | None:
    """``{"arguments": functions of t (the arguments of the law's jumps that name t alone,
    :func:`_arguments`), "generic": the law as a function of t at generic θ, θ̇ and inputs (for a law
    naming inputs, else None), "timed_by": the inputs an argument names beside t}``, kept in the laws'
    cache by the law's text (latdyn.scene.expressions: a run whose laws are cached imports no SymPy);
    None where the text cannot be read back."""
    from latdyn.scene import expressions as cache

    source = f"jump arguments 1:{type(law).__name__}:{law.source}"
    entry = cache.cached_entry("jumps", source)
    if entry is not None:
        return {"arguments": tuple(entry.get("arguments") or ()), "generic": (entry.get("generic") or (None,))[0],
                "timed_by": list(entry.get("timed_by") or ())}
    found = _law_expression(law)
    if found is None:
        return None
    import sympy as sp

    expr, t, inputs = found
    functions = tuple(sp.lambdify(t, a, modules="numpy") for a in _arguments(expr, t))
    timed_by = sorted({s.name for a in _arguments(expr, t, t_alone=False)
                       if t in a.free_symbols for s in a.free_symbols if s in inputs})
    generic = None
    if inputs:
        others = {s: 0.3 + 0.17 * k for k, s in enumerate(sorted(expr.free_symbols - {t}, key=lambda s: s.name))}
        generic = sp.lambdify(t, expr.subs(others), modules="numpy")
    cache.keep_entry("jumps", source, {"timed_by": timed_by},
                 {"arguments": functions, "generic": None if generic is None else (generic,)},
                 [(0.1,), (0.37,), (1.3,)])
    return {"arguments": functions, "generic": generic, "timed_by": timed_by}


def _generic_values_in_time(law, arguments: dict):
    """The law at generic θ, θ̇ and inputs as a function of an array of t (a law naming inputs), else None."""
    generic = arguments["generic"]
    if generic is None:
        return None
    return lambda times: np.broadcast_to(np.asarray(generic(times), float), np.shape(times))


def _laws(scene):
    """(key, law) of every law of ``scene`` that may name t: load components, hinge and guide laws,
    prescribed angles, slides and motions, cables' rest lengths, continuous controllers' outputs."""
    for i, load in enumerate(scene.loads):
        for kind in ("force", "moment"):
            for j, component in enumerate(getattr(load, kind) or []):
                yield f"loads[{i}].{kind}[{j}]", component
    for beam, which, hinge in scene.hinges:
        for key in ("stiffness", "damping", "torque", "angle"):
            yield f"beams.{beam}.{which}.hinge.{key}", getattr(hinge, key)
    for name, body in scene.bodies.items():
        for j, component in enumerate(body.translation or []):
            yield f"bodies.{name}.motion.translation[{j}]", component
        yield f"bodies.{name}.motion.rotation.angle", body.rotation_angle
        if body.guide is not None:
            for key in ("stiffness", "damping", "force", "position"):
                yield f"bodies.{name}.guide.{key}", getattr(body.guide, key)
    for name, cable in (getattr(scene, "cables", None) or {}).items():
        yield f"cables.{name}.rest_length", cable.rest_length
    for name, controller in (getattr(scene, "controllers", None) or {}).items():
        yield f"controllers.{name}.output", controller


def _controller_expression(controller):
    """(SymPy expression, its t symbol) of a continuous controller's output that may jump, else None."""
    text, expr = controller.output_text, controller.output_expr
    if controller.sampled or not isinstance(text, str) or not _JUMPING.search(text) or expr is None \
            or not controller.symbols:
        return None
    return expr, controller.symbols[0]


def _values_in_time(law):
    """The law as a function of t alone (its compiled value; a hinge or guide law's other variables at
    fixed generic values), for a law whose text may jump; else None. No SymPy: the value functions come
    from the laws' cache."""
    if law is None or isinstance(law, (int, float)):
        return None
    source = getattr(law, "source", None)
    if not isinstance(source, str) or not _JUMPING.search(source) or not _NAMES_T.search(source):
        return None
    if hasattr(law, "d_theta"):          # a hinge (or guide) law f(θ, θ̇, t)
        return lambda t: law.values_in_time(0.3, 0.47, t)
    return lambda t: np.asarray(law.value(np.asarray(t, float)), float)


def _jumps_of_values(f, t_end: float) -> list[float]:
    """The times in (0, t_end] where ``f`` jumps: every interval of :data:`SAMPLES` (offset by an
    irrational fraction, so that no jump at a round time falls on a sample; t_end the last) whose
    change is more than :data:`CONTINUOUS` of the values is halved, all at once, keeping the half that
    changes most, down to round-off; it is a jump where the change left is more than
    :data:`CONTINUOUS` of the values (a steep smooth law's change vanishes). Two jumps inside one
    interval, or a jump on an oscillation that changes more in the other half, may be missed here:
    the zeros of the jumps' arguments in the law's text (:func:`_zeros_of_jumps`) find those."""
    offset = 0.5 * (np.sqrt(5.0) - 1.0)
    times = np.concatenate([[1e-9 * t_end], t_end * (np.arange(SAMPLES) + offset) / SAMPLES, [t_end]])
    with np.errstate(all="ignore"):
        values = np.asarray(f(times), float)
    change = np.abs(np.diff(values))
    if not np.all(np.isfinite(change)):
        return []
    candidates = np.flatnonzero(change > CONTINUOUS * (1.0 + np.abs(values[:-1]) + np.abs(values[1:])))
    lo, hi = times[candidates], times[candidates + 1]
    f_lo, f_hi = values[candidates], values[candidates + 1]
    with np.errstate(all="ignore"):
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            moving = (mid > lo) & (mid < hi)
            if not moving.any():
                break
            f_mid = np.asarray(f(mid), float)
            left = moving & (np.abs(f_mid - f_lo) >= np.abs(f_hi - f_mid))
            right = moving & ~left
            hi, f_hi = np.where(left, mid, hi), np.where(left, f_mid, f_hi)
            lo, f_lo = np.where(right, mid, lo), np.where(right, f_mid, f_lo)
    jumped = np.abs(f_hi - f_lo) > CONTINUOUS * (1.0 + np.abs(f_lo) + np.abs(f_hi))
    return [float(t) for t in hi[jumped]]


def input_timed_jump_key(scene) -> str | None:
    """The key of the first law of ``scene`` whose jump's instant depends on an input (the argument of
    its Heaviside or sign, or a Piecewise condition, names t and an input: ``Heaviside(t - T0)``), else
    None: the jump grid is found once, so a run whose inputs change (``latdyn.Simulation``, the FMU)
    refuses such a law (:class:`latdyn.stepping.simulation.Simulation`)."""
    for key, law in _laws(scene):
        if not getattr(law, "input_names", None) or _values_in_time(law) is None:
            continue
        arguments = _jump_arguments(law)
        if arguments is not None and arguments["timed_by"]:
            return key
    return None


def _arguments(expr, t, t_alone: bool = True) -> list:
    """The arguments of ``expr``'s jumps (that depend on ``t`` alone, unless not ``t_alone``): of
    Heaviside and sign, and lhs − rhs of every relation in a Piecewise's conditions."""
    import sympy as sp

    found = [atom.args[0] for atom in expr.atoms(sp.Heaviside, sp.sign)]
    for piecewise in expr.atoms(sp.Piecewise):
        for _, condition in piecewise.args:
            relations = [condition] if isinstance(condition, sp.core.relational.Relational) \
                else list(getattr(condition, "atoms", lambda *_: [])(sp.core.relational.Relational))
            found += [r.lhs - r.rhs for r in relations]
    return [a for a in found if a.free_symbols == {t}] if t_alone else found


def _zeros_of_jumps(expr, t, t_end: float) -> list[float]:
    """The times in [0, t_end] where an argument of a jump of ``expr`` (:func:`_arguments`)
    changes sign or is zero (:func:`_zeros_in_time`)."""
    import sympy as sp

    return _zeros_in_time([sp.lambdify(t, a, modules="numpy") for a in _arguments(expr, t)], t_end)


def _zeros_in_time(arguments, t_end: float) -> list[float]:
    """The times in [0, t_end] where one of ``arguments`` (functions of t) changes sign or is zero:
    bracketed on :data:`SAMPLES` points and bisected to round-off."""
    zeros: list[float] = []
    grid = np.linspace(0.0, t_end, SAMPLES + 1)
    for g in arguments:
        with np.errstate(all="ignore"):
            values = np.broadcast_to(np.asarray(g(grid), dtype=float), grid.shape)
        signs = np.sign(values)
        zeros += [float(grid[i]) for i in np.flatnonzero(signs == 0.0)]
        for i in np.flatnonzero(signs[:-1] * signs[1:] < 0):
            lo, hi, below = float(grid[i]), float(grid[i + 1]), signs[i]
            with np.errstate(all="ignore"):
                for _ in range(200):
                    mid = 0.5 * (lo + hi)
                    if mid in (lo, hi):
                        break
                    if np.sign(float(g(mid))) == below:
                        lo = mid
                    else:
                        hi = mid
                zeros.append(hi if abs(float(g(hi))) <= abs(float(g(lo))) else lo)
    return zeros


def _generic_function(expr, t):
    """``expr`` as a function of an array of t, its other variables at fixed generic values."""
    import sympy as sp

    others = sorted(expr.free_symbols - {t}, key=lambda s: s.name)
    f = sp.lambdify([t, *others], expr, modules="numpy")
    generic = [0.3 + 0.17 * k for k in range(len(others))]
    return lambda times: np.broadcast_to(np.asarray(f(times, *generic), float), np.shape(times))


def _jumps_at(expr, t, time: float, side: float) -> bool:
    """Whether ``expr`` (in t and maybe other variables, set to fixed generic values) takes values
    ``side`` before and after ``time`` that differ by more than :data:`CONTINUOUS` of their size."""
    import sympy as sp

    others = sorted(expr.free_symbols - {t}, key=lambda s: s.name)
    generic = {s: 0.3 + 0.17 * k for k, s in enumerate(others)}
    f = sp.lambdify([t, *others], expr, modules="numpy")
    with np.errstate(all="ignore"):
        before, after = (float(f(time + sign * side, *generic.values())) for sign in (-1.0, 1.0))
    if not (np.isfinite(before) and np.isfinite(after)):
        return False
    return abs(after - before) > CONTINUOUS * (1.0 + abs(before) + abs(after))
