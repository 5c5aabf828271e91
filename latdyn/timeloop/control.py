"""Where the steps of the time loop go, and how long they are (SCENE.md ``solve``: ``t_end``, ``dt``,
``dt_min``, ``adaptive``, ``error_tol``; ``output.every``).

Steps land on the time grid t_k = k·dt (the last one on t_end), computed from the grid index, never
accumulated. A step Newton cannot converge is tried again with the inertia tangent in its iteration
matrix, then cut in half, down to ``dt_min``. With ``adaptive`` steps the integrator's error estimate
e of each converged step rejects it (e > 1: tried again at h·max(0.2, 0.9 e^(−1/3))) or, accepted,
sizes the next one, h·min(2, 0.9 e^(−1/3)) clipped to [dt_min, dt] (after a latch or a stop: 2h; after
a step shortened onto a grid point: the size proposed before it was shortened); a size that would leave
less than itself before the next grid point takes half the way there.
With fixed steps, after a cut or a step shortened onto an event the step grows back to dt by doubling; a
step shortened onto a grid point on the way hands on the doubling of the size proposed before it.

Every run ends: no step is shorter than ``dt_min`` (default dt·10⁻⁶; the loader refuses one below
10⁻¹² t_end, lost in the round-off of t) save the last one onto a grid point; a step that Newton
cannot converge, or that the error estimate rejects, at ``dt_min`` ends the run with a SolverError
(exit 1), and so does a run that crawls — :data:`CRAWL_STEPS` accepted steps in a row averaging
less than the crawling step, min(:data:`CRAWL_FACTOR` · dt_min, :data:`CRAWL_FRACTION` · dt) (events
that re-trigger at the same instant, a motion the error estimate cannot follow; the message names which of
events, Newton's cuts or the error estimate kept the steps short, and its remedy). Without an
accepted step the tried steps only shrink (cut, rejected, shortened onto the grid), so the floor
also bounds the attempts in a row."""
from __future__ import annotations

import sys
from typing import NamedTuple

import numpy as np

from latdyn.errors import SolverError
from latdyn.timeloop.jumps import JUMP_SIDE
from latdyn.timeloop.progress import CUTS_REPORTED, TransientProgress, report_cut

#: A run whose last CRAWL_STEPS accepted steps average less than min(CRAWL_FACTOR · dt_min,
#: CRAWL_FRACTION · dt) is crawling (1e-4 dt with the default dt_min; never above dt/1000, where a
#: dt_min close to dt would make every run crawl).
CRAWL_STEPS = 1000
CRAWL_FACTOR = 100.0
CRAWL_FRACTION = 1e-3


class Resize(NamedTuple):
    """How the step size the control chose last depends on the step it came from (adaptive steps, and fixed
    steps' cuts and their doubling back: the derivative of the controller's formula, which the transient
    sensitivities follow, δh_new =
    ``by_step`` δh + ``by_error`` δerror; latdyn/analyses/adaptive_sensitivities.py): ``by_step`` =
    ∂h_new/∂h, ``by_error`` = ∂h_new/∂error (error: the relative error estimate it read). A clipped
    size (dt, dt_min, a factor at its bound) has the clipping's derivative. ``by_proposed``: ∂h_new/∂h_proposed,
    1 where a step shortened onto a grid point hands on the size proposed before it was shortened."""

    by_step: float
    by_error: float
    error: float
    by_proposed: float = 0.0


class StepControl:
    """The time grid, the rows recorded on it and the step size of one transient run."""

    def __init__(self, solve, every: float | None, length: float, instants: np.ndarray | None = None,
                 jumps: np.ndarray | None = None):
        """``solve``: the scene's solve section; ``every``: ``output.every`` (None: a row every step);
        ``length``: the model's length scale (m), which makes ``error_tol`` relative; ``instants``:
        times the steps must land on besides k·dt (sampled controllers' instants), put on the grid;
        ``jumps``: the times where a law jumps in t (latdyn.timeloop.jumps), put on the grid too, the
        step that reaches one ending :data:`~latdyn.timeloop.jumps.JUMP_SIDE` · dt before it."""
        self.t_end, self.dt = float(solve.t_end), float(solve.dt)
        jumps = np.zeros(0) if jumps is None else np.asarray(jumps, float)
        if len(jumps):
            instants = np.union1d(np.zeros(0) if instants is None else instants, jumps)
        self.n_grid = max(1, int(np.ceil(self.t_end / self.dt - 1e-9)))
        #: the grid's times where instants are added to it (None: k·dt)
        self.grid = None
        #: the grid indices of the instants, sorted (the loop of steps in C stops on each: next_row), and
        #: whether every instant is a point k·dt of the nominal grid (the loop of steps in C walks only that)
        self.instant_indices, self.instants_on_nominal_grid = np.zeros(0, np.int64), True
        #: whether the loop of steps in C samples the sampled controllers itself (the time loop sets it):
        #: then it does not stop on their instants (loop_end)
        self.samples_in_loop = False
        if instants is not None and len(instants):
            self.tolerance = 1e-9 * self.dt
            nominal = [self.grid_time(k) for k in range(self.n_grid + 1)]
            extra = [t for t in instants if t < self.t_end
                     and abs(nominal[min(int(round(t / self.dt)), self.n_grid)] - t) > self.tolerance]
            self.grid = np.unique(np.array(nominal + extra, dtype=float))
            self.n_grid = len(self.grid) - 1
            self.instants_on_nominal_grid = not extra
            found = np.searchsorted(self.grid, np.asarray(instants, float) - self.tolerance)
            self.instant_indices = np.unique(found[found <= self.n_grid]).astype(np.int64)
        #: the grid indices of the laws' jumps (the steps land JUMP_SIDE · dt before each; the loop restarts
        #: JUMP_SIDE · dt after it: :meth:`jump_reached`), and that side in seconds
        self.jump_indices = np.unique(np.searchsorted(self.grid, jumps - self.tolerance)).astype(np.int64) \
            if len(jumps) else np.zeros(0, np.int64)
        self.jump_side = JUMP_SIDE * self.dt
        self.dt_min = solve.dt_min if solve.dt_min is not None else self.dt * 1e-6
        self.adaptive, self.error_tol, self.length = solve.adaptive, solve.error_tol, length
        self.every = every
        self.crawling_step = min(CRAWL_FACTOR * self.dt_min, CRAWL_FRACTION * self.dt)
        # the crawl window: its accepted steps so far and the time it started at; what shrank its steps is
        # counted from the totals at its start (:meth:`_shrunk_by`)
        self.window_steps, self.window_events, self.window_t = 0, 0, None
        self.window_start: tuple[int, int, int] = (0, 0, 0)
        #: adaptive steps: the trials the error estimate rejected in the whole run (:meth:`rejects`)
        self.estimate_rejections = 0
        # where the loop pauses (pause_at): its time and the last grid point not after it; the step
        # that was shortened to land on it, restored once the run is back on the grid
        self.pause, self.pause_index = None, None
        self.h_resume, self.leaving_pause = None, False
        #: the relative error estimate of the last converged trial (rejects) and its size, which
        #: :meth:`estimate_accepted` reuses for the step it accepts when it is that trial
        self.estimated: tuple[float, float] | None = None
        #: adaptive steps: the size the control proposed for the trial :meth:`next_step` shortened onto the next
        #: grid point (None: not shortened), which the step after it takes again (after_accepted)
        self.proposed: float | None = None
        #: adaptive steps: whether :meth:`next_step` took half the way left to the next grid point (the proposed size
        #: would have left less than itself before it): δh = −δt_n/2 (latdyn/analyses/adaptive_sensitivities.py)
        self.halved = False
        #: the accepted step's relative error estimate, taken before the integrator accepts it (after that
        #: a_n = a_{n+1} and the estimate reads 0), which sizes the next step (after_accepted)
        self.accepted_error = 0.0
        #: how the last size chosen (rejects, after_newton_failure, after_accepted) depends on the step it
        #: came from (:class:`Resize`); None where it does not follow from it (a pause's restored step)
        self.resize: Resize | None = None

    # ------------------------------------------------------------------------- the grid and its rows
    def grid_time(self, k: int) -> float:
        """t_k = k·dt, computed (the last grid point is t_end exactly); with instants, the k-th time of the grid."""
        if self.grid is not None:
            return float(self.grid[min(k, self.n_grid)])
        return self.t_end if k >= self.n_grid else k * self.dt

    def finished(self, run: TransientProgress) -> bool:
        return run.grid_index >= self.n_grid

    def on_grid(self, run: TransientProgress) -> bool:
        """Whether the next step is a nominal one from a grid point (the loop of steps in C takes those)."""
        return run.h == self.dt and run.state.t == self.grid_time(run.grid_index)

    def next_step(self, run: TransientProgress) -> tuple[float, bool, float | None]:
        """The step to try from ``run.state``: its size, whether it lands on the next grid point
        (within 1e-9 of the step: then exactly), and the time it ends at exactly when it lands on
        that grid point or on the pause (:meth:`pause_at`) before it, else None. Adaptive steps: a
        size that would leave less than itself before the grid point takes half the way there
        (:attr:`halved`), so that no sliver is left."""
        target = self.grid_time(run.grid_index + 1)
        h, self.halved = run.h, False
        if self.pause is not None and self.pause < target:  # the pause comes first (off the grid)
            if h < (self.pause - run.state.t) * (1 - 1e-9):
                return h, False, None
            self.h_resume = h
            return self.pause - run.state.t, False, self.pause
        jump = run.grid_index + 1 in self.jump_indices
        if jump:   # the step that reaches a law's jump ends just before it, on the law as it was
            target -= self.jump_side
        left = target - run.state.t
        lands = h >= left * (1 - 1e-9)
        if lands:
            h = left
        elif self.adaptive and 2 * h > left and 0.5 * left >= self.dt_min:
            # the step would leave a sliver before the grid point, whose tiny step threw the next one's
            # estimate off: the way left in two equal halves
            h, self.halved = 0.5 * left, True
        self.proposed = run.h if lands and h < run.h else None
        return h, lands, target if lands else None

    def jump_reached(self, run: TransientProgress) -> float | None:
        """The time just after the law's jump the run's last accepted step landed before (the loop
        restarts there: latdyn.timeloop.jumps), else None; None at t_end (a jump there ends the run
        :data:`~latdyn.timeloop.jumps.JUMP_SIDE` · dt before it, on the law as it was)."""
        if run.grid_index not in self.jump_indices or run.grid_index >= self.n_grid:
            return None
        jump = self.grid_time(run.grid_index)
        if abs(run.state.t - (jump - self.jump_side)) > 0.5 * self.jump_side:
            return None
        return jump + self.jump_side

    # ------------------------------------------------------------------------- a pause (stepping from Python)
    def pause_at(self, t: float | None) -> None:
        """Steps land on time ``t`` and the loop pauses there (:meth:`paused`;
        :class:`latdyn.stepping.simulation.Simulation`): a ``t`` within 1e-9 dt of a grid point is
        that point (the loop of steps in C stops on it); between grid points, the step that would
        cross ``t`` is shortened to land on it exactly, the step after it goes on to the next grid
        point, and the steps after that have the size the shortened one had. None: no pause."""
        if t is None:
            self.pause = self.pause_index = None
            return
        if self.grid is None:
            below = min(self.n_grid, int(np.floor(t / self.dt)))
        else:  # sample instants on the grid
            below = min(self.n_grid, max(0, int(np.searchsorted(self.grid, t, side="right")) - 1))
        for k in (below, below + 1):
            if k <= self.n_grid and abs(t - self.grid_time(k)) <= 1e-9 * self.dt:
                self.pause, self.pause_index = self.grid_time(k), k
                return
        self.pause, self.pause_index = float(t), below

    def paused(self, run: TransientProgress) -> bool:
        """Whether the run has reached the pause (a step landed on it)."""
        return self.pause is not None and run.state.t >= self.pause

    def before_pause(self, run: TransientProgress) -> bool:
        """Whether the pause comes before the next grid point (the next step, shortened onto it, is
        taken from Python)."""
        return self.pause is not None and self.pause_index <= run.grid_index

    def row_due(self, run: TransientProgress, t: float) -> bool:
        """Whether the step that ended at ``t`` is recorded: every output time, and t_end always."""
        return self.every is None or t >= run.output_index * self.every - 1e-9 * self.dt or self.finished(run)

    def row_recorded(self, run: TransientProgress, t: float) -> None:
        """After the row at ``t``: the next output time."""
        if self.every:
            run.output_index = int(np.floor(t / self.every + 1e-9 * self.dt / self.every)) + 1

    def next_row(self, run: TransientProgress) -> int:
        """The grid point of the next recorded row (every step without ``every``), and at most the
        loop's end (:meth:`loop_end`: a multiple of 256 steps, the pause, the next sample instant)."""
        k = run.grid_index + 1
        if self.every is not None:
            due_at = run.output_index * self.every - 1e-9 * self.dt
            k = max(k, min(self.n_grid, int(np.floor(due_at / self.dt))))
            while k > run.grid_index + 1 and self.grid_time(k - 1) >= due_at:
                k -= 1
            while k < self.n_grid and self.grid_time(k) < due_at:
                k += 1
        return min(k, self.loop_end(run))

    def loop_end(self, run: TransientProgress) -> int:
        """The grid point a loop of steps in C ends at, rows or none on the way: t_end, the pause, the
        step that ends on a multiple of 256 steps (where the loop puts rotations back on SO(3)), or the
        next sample instant of a sampled controller unless the loop samples itself
        (:attr:`samples_in_loop`; latdyn.timeloop.sampling)."""
        k = min(self.n_grid, run.grid_index + 256 - run.steps % 256)
        if self.pause_index is not None and self.pause_index > run.grid_index:
            k = min(k, self.pause_index)
        following = self.instant_indices[self.instant_indices > run.grid_index]
        if len(following) and not self.samples_in_loop:
            k = min(k, int(following[0]))
        jumps = self.jump_indices[self.jump_indices > run.grid_index + 1]
        if len(jumps):   # the grid point before a law's jump: the step that lands before it is Python's (next_step)
            k = min(k, int(jumps[0]) - 1)
        return k

    def before_jump(self, run: TransientProgress) -> bool:
        """Whether the next step reaches a law's jump (it ends :attr:`jump_side` before it: :meth:`next_step`;
        the time loop takes it from Python, and the restart after it: :meth:`jump_reached`)."""
        return run.grid_index + 1 in self.jump_indices

    # ------------------------------------------------------------------------- the step size
    def relative_error(self, integrator, h: float) -> float:
        """The integrator's error estimate of its last step, relative to ``error_tol`` · length."""
        return integrator.error_estimate(h) / (self.error_tol * self.length)

    def at_minimum(self, h: float) -> bool:
        """Whether a step of size ``h`` is at (or, landing on a grid point, below) ``dt_min``."""
        return h <= self.dt_min * (1 + 1e-9)

    def rejects(self, run: TransientProgress, integrator, h: float) -> bool:
        """Adaptive steps: whether the converged step of size ``h`` is rejected by its error
        estimate; then the step to try instead (at least ``dt_min``). A step at ``dt_min`` that
        the estimate rejects ends the run (SolverError)."""
        if not self.adaptive:
            return False
        error = self.relative_error(integrator, h)
        self.estimated = (h, error)
        if error <= 1.0:
            return False
        run.rejected_steps += 1
        self.estimate_rejections += 1
        if self.at_minimum(h):
            raise SolverError(
                "the error estimate rejects the step at the minimum step",
                f"at t = {run.state.t + h:.6g} the step {h:.3g} (dt_min = {self.dt_min:.3g}) has an error estimate "
                f"{error:.3g} times error_tol: the motion is not smooth at that scale there (a finite-time "
                "blow-up, a law or load that jumps, events that re-trigger at the same instant), or "
                "error_tol asks for steps below dt_min; the run ends here rather than retry it.")
        run.h, self.resize = self._sized(h, error, 0.2, 0.9)   # e > 1: a factor below 0.9, never past dt
        return True

    def _sized(self, h: float, error: float, least: float, most: float) -> tuple[float, Resize]:
        """The next size h · clip(0.9 e^(−1/3), ``least``, ``most``) clipped to [dt_min, dt] after a step of size
        ``h`` with relative error estimate ``error``, and its derivative (:class:`Resize`): 0 where the size is
        clipped, the factor's bound where the factor is, else ∂h'/∂h = f, ∂h'/∂e = −h f / (3e)."""
        factor = 0.9 * max(error, 1e-10) ** (-1 / 3)
        size = min(self.dt, max(self.dt_min, h * min(most, max(least, factor))))
        if size in (self.dt, self.dt_min):
            return size, Resize(0.0, 0.0, error)
        if factor <= least or factor >= most:
            return size, Resize(least if factor <= least else most, 0.0, error)
        return size, Resize(factor, -h * factor / (3 * error), error)

    def estimate_accepted(self, integrator, h: float) -> None:
        """Adaptive steps: keep the relative error estimate of the converged step of size ``h`` the loop is
        about to accept, before ``integrator.accept()`` (:attr:`accepted_error`); :meth:`rejects` evaluated it
        on that step unless the step was shortened since (onto an event), then it is evaluated here."""
        if not self.adaptive:
            return
        if self.estimated is not None and self.estimated[0] == h:
            self.accepted_error = self.estimated[1]
        else:
            self.accepted_error = self.relative_error(integrator, h)
        self.estimated = None

    def after_newton_failure(self, run: TransientProgress, integrator, h: float, iterations: int) -> bool:
        """Newton did not converge in the step of size ``h`` from ``run.state``: the step is tried
        again with the inertia tangent if the iteration matrix leaves it out, else cut in half.
        False: half the step would be below ``dt_min``."""
        run.rejected_steps += 1
        t = run.state.t
        if not getattr(integrator, "inertia_tangent", True):
            # the iteration matrix leaves out the inertia tangent, which is exact only where
            # β′M dominates it (latdyn.step.integrators); take it from here on, same step
            integrator.inertia_tangent = True
            run.inertia_tangent_from = float(t)
            # run.h is unchanged (the size proposed, the trial shortened onto a grid point or not): the carried
            # derivative of the next trial's size stays as it is (a by_step of 1 would take the shortened size's)
            self.resize = Resize(0.0, 0.0, 0.0, 1.0)
            print(f"latdyn: Newton did not converge in {iterations} iterations at t = {t + h:.9g}; "
                  "its matrix now includes the inertia tangent (directions with little inertia)",
                  file=sys.stderr)
            return True
        if h / 2 < self.dt_min:
            return False
        report_cut(run, t + h, h, iterations)
        run.h = h / 2
        self.resize = Resize(0.5, 0.0, 0.0)
        return True

    def after_far_root(self, run: TransientProgress, h: float, hinge: str, distance: float) -> None:
        """Newton converged in the step of size ``h`` from ``run.state`` to a root that puts ``hinge`` ``distance``
        (> π) from its predictor (:func:`latdyn.timeloop.progress.far_root`: a whole turn away, no motion): the
        step is cut in half, as after a failure of Newton, and never treated as a crossing to land on. Half the step
        below ``dt_min`` ends the run (SolverError)."""
        run.rejected_steps += 1
        t = run.state.t
        if h / 2 < self.dt_min:
            raise SolverError(
                "the step converges to a root far from its predictor at the minimum step",
                f"from t = {t:.9g} the step {h:.3g} (dt_min = {self.dt_min:.3g}) puts hinge {hinge} {distance:.3g} rad "
                "from its predictor (more than π: a root a whole turn away, no motion the step resolved); the run "
                "ends here rather than accept it (a smaller dt, or a hinge law that does not drive the hinge through "
                "a turn within a step).")
        run.far_roots += 1
        if run.far_roots <= CUTS_REPORTED:
            print(f"latdyn: the step from t = {t:.9g} of {h:.3g} converged to a root that puts hinge {hinge} "
                  f"{distance:.3g} rad from its predictor (more than π: a whole turn away, no motion); step cut to "
                  f"{h / 2:.3g}", file=sys.stderr)
        run.h = h / 2
        self.resize = Resize(0.5, 0.0, 0.0)

    def after_accepted(self, run: TransientProgress, integrator, h: float, latched: bool, stopped: bool,
                       lands: bool = False) -> None:
        """The step to try after the accepted step of size ``h`` that ended at ``run.state`` (``latched``:
        a hinge latched or hit a stop in it; ``stopped``: a stop; ``lands``: it ended on the grid point
        :meth:`next_step` aimed it at). A run that crawls ends here (SolverError).

        Adaptive steps: h' = min(dt, max(dt_min, h · min(2, 0.9 e^(−1/3)))), e the step's own relative
        error estimate (:meth:`estimate_accepted`); after a latch or a stop e is taken as 0 (2h); after a
        step shortened onto a grid point, h' is the size proposed before it was shortened (a sliver left
        before the grid point says nothing of the steps after it). Fixed steps: after a stop dt; after a
        step shortened onto a grid point 2 h_proposed (the same reason), else 2h, up to dt."""
        self._watch_crawl(run, h, latched)
        self.resize = None
        if self.h_resume is not None:  # shortened only to land on the pause, then back on the grid
            if not (latched or stopped) and run.state.t == self.pause:
                run.h, self.leaving_pause = self.h_resume, True
                return
            if not (latched or stopped) and self.leaving_pause:  # the step from the pause
                run.h = self.h_resume
                self.h_resume, self.leaving_pause = None, False
                return
            self.h_resume, self.leaving_pause = None, False
        if self.adaptive and lands and not latched and self.proposed is not None and h < self.proposed:
            run.h, self.resize = self.proposed, Resize(0.0, 0.0, 0.0, 1.0)
        elif self.adaptive:
            # the accepted step's own estimate (estimate_accepted); after a latch or a stop the
            # accelerations restart, so the step's estimate says nothing of the next one: taken as 0
            error = 0.0 if latched else self.accepted_error
            run.h, self.resize = self._sized(h, error, 0.2, 2.0)
        elif stopped:
            run.h, self.resize = self.dt, Resize(0.0, 0.0, 0.0)  # after an impact on a stop: the nominal step
        elif self._grown_from(h, lands) != h:
            # a step shortened onto a grid point: the steps grow on from the size proposed before the shortening
            # (a sliver before a grid point says nothing of the steps after it; growing from the sliver made
            # the sequence of steps, and the results with it, jump with Newton's last iterates)
            run.h = min(self.dt, 2 * self.proposed)
            self.resize = Resize(0.0, 0.0, 0.0, 2.0 if 2 * self.proposed < self.dt else 0.0)
        elif h < self.dt:
            run.h = min(self.dt, 2 * h)  # recover the nominal step after a cut or a shortened step
            self.resize = Resize(2.0 if 2 * h < self.dt else 0.0, 0.0, 0.0)
        else:
            self.resize = Resize(0.0, 0.0, 0.0, 1.0)   # run.h as it was

    def _grown_from(self, h: float, lands: bool) -> float:
        """The size fixed steps grow back from after the accepted step of size ``h`` (``lands``: it ended on the grid
        point :meth:`next_step` aimed it at): the size proposed before a step was shortened onto a grid point, else h
        (:meth:`after_accepted`)."""
        return self.proposed if lands and self.proposed is not None and h < self.proposed else h

    def grows_back_short(self, h: float, lands: bool) -> bool:
        """Whether fixed steps not restarted (:meth:`after_accepted`'s last branches) try a step shorter than dt after
        the accepted step of size ``h`` (``lands`` as there): twice :meth:`_grown_from` below dt. Called before
        :meth:`after_accepted`."""
        return not self.adaptive and 2 * self._grown_from(h, lands) < self.dt

    def restart_differs(self, run: TransientProgress, h: float, lands: bool) -> bool:
        """Whether the restart at dt after the accepted step of size ``h`` that ended at ``run.state`` (``lands`` as
        in :meth:`after_accepted`, the run's grid index past it) makes the next step other than fixed steps not
        restarted take: they grow back short (:meth:`grows_back_short`) and do not reach the next grid point, which
        the restart's step reaches or comes nearer to. Called before :meth:`after_accepted`."""
        if not self.grows_back_short(h, lands):
            return False
        left = self.grid_time(run.grid_index + 1) - run.state.t
        return 2 * self._grown_from(h, lands) < left * (1 - 1e-9)

    def _watch_crawl(self, run: TransientProgress, h: float, event: bool) -> None:
        """Count the accepted step of size ``h`` (``event``: it ended on a latch or a stop) into the
        crawl window; a full window that advanced less than CRAWL_STEPS crawling steps ends the run,
        its message naming what kept the steps short (:meth:`_shrunk_by`) and the remedy for that."""
        if self.window_t is None:
            self.window_t, self.window_steps, self.window_events = run.state.t - h, 0, 0
            self.window_start = self._totals(run)
        self.window_steps += 1
        self.window_events += bool(event)
        if self.window_steps < CRAWL_STEPS:
            return
        advanced = run.state.t - self.window_t
        if advanced < CRAWL_STEPS * self.crawling_step:
            raise SolverError(
                "the time step stays near the minimum step",
                f"{CRAWL_STEPS} steps from t = {self.window_t:.9g} to t = {run.state.t:.9g} advanced {advanced:.3g}, "
                f"on average {advanced / CRAWL_STEPS:.3g} a step, less than {self.crawling_step:.3g} (dt = {self.dt:.3g}, "
                f"dt_min = {self.dt_min:.3g}); " + self._shrunk_by(run)
                + "; the run ends here rather than crawl.")
        self.window_t, self.window_steps, self.window_events = run.state.t, 0, 0
        self.window_start = self._totals(run)

    def _totals(self, run: TransientProgress) -> tuple[int, int, int]:
        """The run's trials so far rejected by the error estimate, cut after Newton failed, and cut for a far root."""
        return self.estimate_rejections, getattr(run, "newton_cuts", 0), getattr(run, "far_roots", 0)

    def _shrunk_by(self, run: TransientProgress) -> str:
        """What kept the crawl window's steps short, and its remedy: events that re-trigger at the same instant,
        Newton's cuts (or cuts for far roots), or, with adaptive steps, the error estimate that sizes them."""
        rejected, cuts, far = (now - then for now, then in zip(self._totals(run), self.window_start))
        counts = (f"{self.window_events} of them ended on a latch or a stop; in them the error estimate rejected "
                  f"{rejected} trials, Newton's failures cut {cuts} and far roots {far}")
        if self.window_events:
            return (counts + " (events that re-trigger at the same instant: a stop chattering; a motion meant "
                    "to need such steps: a smaller solve.dt_min)")
        if cuts + far > rejected or not self.adaptive:
            return (counts + " (Newton does not converge at a larger step: a motion it cannot follow there; "
                    "a motion meant to need such steps: a smaller solve.dt_min)")
        tol = self.error_tol * self.length
        return (counts + f" (the error estimate sizes the adaptive steps: error_tol = {self.error_tol:.3g} asks for a "
                f"local error of at most {tol:.3g} m a step (error_tol · length {self.length:.3g} m), which only steps "
                "this short meet; a larger solve.error_tol (the steps grow as its cube root); a motion meant to need "
                "such steps: a smaller solve.dt_min)")
