"""Which event comes first in a step, and the search on the step's size that lands on it: one rule for the run
without sensitivities (latdyn.timeloop.loop.TimeLoop._landing) and the run with them
(latdyn.analyses.transient_sensitivities.TransientSensitivities.land). Both land on a hinge's event to
:data:`LANDING` by :func:`land`; with sensitivities, whose event-time derivative assumes the step ends on the event,
a landing that ends elsewhere is refused, and a cable element's change is landed on alike (to :data:`LANDING` · EA),
where the run without takes its own regula falsi on the trial ends (TimeLoop._cable_landing, docs/cables.md).

The events, in the order of the step (linear interpolation of the angle and of the cable element's gap from the
step's start): a hinge crossing its lock_at or a stop from inside (a rigid stop's impact or a compliant stop's
onset), a cable element's gap crossing zero from the side the step held it on; else (nothing crossed) a hinge that
ended within the events' tolerance of its lock_at, or a cable element the events turn over (its gap within the
tolerance, moving towards zero). The two runs chose otherwise before (hinges first with sensitivities, then cables;
both by fraction without): fuzz8's finding 2 (tests/test_fuzz_run_findings7.py) was the difference."""
from __future__ import annotations

from typing import Callable, NamedTuple

from latdyn.timeloop.events import cable_crossings, cable_events, cable_gaps, lock_events, stop_crossings


#: |θ − θ_event| (rad, times max(1, |θ_event|)) to which a step lands on a latch or a stop, with sensitivities or
#: without, and |g| (times the element's EA) on a cable element's change with sensitivities (the events' own
#: tolerances, lock_tolerance 1e-7 and cable_tolerance 1e-9 EA, say which steps reach an event; this one where a
#: landing aims)
LANDING = 1e-12
#: retries at most of a landing's search (:func:`land`)
LANDING_PASSES = 30


class Event(NamedTuple):
    """The first event of a step: ``fraction`` of the step at its crossing (None: reached at the step's end, not
    crossed), ``hinge`` and ``at`` (its lock_at or stop) or ``element`` (a cable element)."""
    fraction: float | None
    hinge: int | None = None
    at: float | None = None
    element: int | None = None

    def tight(self, assembler) -> float:
        """The landing's tolerance on :meth:`gap`: :data:`LANDING` · max(1, |at|), or :data:`LANDING` · EA."""
        if self.hinge is not None:
            return LANDING * max(1.0, abs(self.at))
        return LANDING * float(assembler.model.cables.EA[self.element])

    def gap(self, assembler) -> Callable:
        """gap(state): the hinge's angle less its lock_at or stop, or the cable element's min(N_el, N); zero on
        the event."""
        if self.hinge is not None:
            k, at = self.hinge, self.at
            return lambda state: float(state.theta[k] - at)
        e = self.element
        return lambda state: float(cable_gaps(assembler, state)[0][e])


def first_event(assembler, old, new, cables: bool = True, cable_floor: float = 0.0,
                reached: bool = True) -> Event | None:
    """The first event over the step old → new (module docstring), or None; ``cables``: cable elements too;
    ``cable_floor``: the fraction below which an element changing back (it changed side at the step's start) is
    taken at the floor (latdyn.timeloop.events.CABLE_LANDING); ``reached``: events reached at the step's end,
    crossed by none, too. A hinge's crossing and a cable element's at the same fraction: the hinge's."""
    model = assembler.model
    found = []
    if any(model.hinges[k].lock_at is not None or model.hinges[k].limits is not None for k in model.free_hinges):
        latched, crossing = lock_events(assembler, old, new)
        found += [(f, 0, k, model.hinges[k].lock_at) for k, f in crossing]
        found += [(f, 0, k, model.hinges[k].limits[0 if side < 0 else 1]) for k, side, f in
                  stop_crossings(assembler, old, new)]
    else:
        latched = []
    crossed_cables = cables and model.cables is not None
    if crossed_cables:
        found += [(max(f, cable_floor) if back else f, 1, e, None) for e, f, back in cable_crossings(assembler, old, new)]
    if found:
        f, kind, index, at = min(found)
        if kind == 0:
            return Event(float(f), hinge=int(index), at=float(at))
        return Event(float(f), element=int(index))
    if not reached:
        return None
    if latched:
        k = latched[0]
        return Event(None, hinge=int(k), at=float(model.hinges[k].lock_at))
    if crossed_cables:
        sides = list(model.cables.sides)
        turned, _ = cable_events(assembler, sides, old, new)
        for e, (a, b) in enumerate(zip(sides, turned)):
            if a != b:
                return Event(None, element=e)
    return None


def land(step, old, attempt, gap: Callable, tight: float, passes: int, shortest: float = 0.0):
    """The step from ``old`` shortened onto gap = 0 to |gap| ≤ ``tight``: regula falsi on the step's size from 0
    and the step tried (``attempt``: (state, stats, h, lands)), Illinois-modified while the zero is bracketed, a
    secant where it is not, at most ``passes`` retries, none shorter than ``shortest``; ``step(h)`` takes a step of
    size h from ``old`` and returns (state, stats). Returns the last converged step, (state, stats, h, lands).

    The plain secant through the last two trials left the zero where the gap is not monotone in the step's size (a
    damped cable going taut: −20 at 0, +5.1 at 0.89 h, +2.5 at h; its next trial fell past h and the landing stopped
    5e-5 off: benchmarks/fuzz_sensitivities.py, tests/test_sensitivities_fuzz_finds.py); the secant from the step's
    start through each retry that the run without sensitivities took ended short of a compliant stop's onset
    whenever the retry did (3e-5 s short, then slivers of 3e-5 and 4.3e-7 s, 59 steps where this landing takes 45:
    fuzz7's finding 4, tests/test_fuzz_run_findings6.py)."""
    new, stats, h, lands = attempt
    a, ga = 0.0, gap(old)
    b, gb = h, gap(new)
    bracketed = ga * gb < 0.0
    best = attempt
    for _ in range(passes):
        if abs(gb) <= tight or gb == ga:
            break
        c = max(b - gb * (b - a) / (gb - ga), shortest)
        if not 0.0 < c <= h * (1 + 1e-12) or c == b:
            break
        retry, retry_stats = step(c)
        if not retry_stats.converged:
            break
        best = (retry, retry_stats, c, False)
        gc = gap(retry)
        if not bracketed or gc * gb < 0.0:
            a, ga = b, gb
        else:
            ga = 0.5 * ga
        b, gb = c, gc
    return best
