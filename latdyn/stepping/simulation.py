"""A transient run stepped from Python (SCENE.md, "Stepping from Python"; docs/stepping.md).

``sim = Simulation(scene, out_dir=None)`` prepares the scene and records its row at t = 0, as
``latdyn run`` does; ``sim.advance_to(t)`` steps the time loop (:mod:`latdyn.timeloop.loop`, the
same loop, compiled steps and events as ``latdyn run``) to ``t`` and pauses there; ``sim.probes()``
reads the probes at ``sim.t``; ``sim.set_input(NAME, value)`` sets one of the scene's ``inputs``
for the steps that follow; ``sim.close()`` finishes the result files and returns the
:class:`~latdyn.results.result.Result`.

Where the steps go: on the run's grid t_k = k·dt (``solve.dt``); a pause ``t`` between two grid
points shortens the step that would cross it to land on it exactly, and the next step goes on to
the next grid point. Paused only on grid points (and with the inputs unchanged), the steps, rows
and probes are those of one ``latdyn run`` of the scene, to round-off.

A changed input is a jump of the laws that read it at the pause: the integrator goes on from the
accelerations of the equations of motion at the pause under the new value, the directions stiff at
the scale of dt taken quasi-statically as after an impact (:meth:`latdyn.timeloop.loop.TimeLoop.restart`);
set before the first advance, the start is made again as if the scene gave that value."""
from __future__ import annotations

import copy
import math
import time

from latdyn.errors import SceneError, UnboundedError
from latdyn.results.result import Result
from latdyn.scene.loader import Scene, load_scene
from latdyn.solve import _compile_seconds, close_run, open_run, write_linear_model_first
from latdyn.timeloop.jumps import input_timed_jump_key, prescribed_positions
from latdyn.timeloop.transient import start_transient

#: A time within this fraction of ``solve.dt`` of ``sim.t``, a grid point or ``solve.t_end`` is that time.
TIME_TOLERANCE = 1e-9


def _refuse_jumps_timed_by_inputs(scene) -> None:
    """A law whose jump in t falls at a time an input gives (``Heaviside(t - T0)``, T0 an input) is
    refused (SceneError naming it): the steps land on the laws' jumps found once at the start
    (latdyn.timeloop.jumps), and set_input would move this one off them."""
    key = input_timed_jump_key(scene)
    if key is not None:
        raise SceneError(scene.file, key,
                         "a law whose jump in t falls at a time an input gives (an input inside the argument of "
                         "Heaviside or sign, or a Piecewise condition in t): a run stepped from Python may change "
                         "the input, and the steps land only on the jumps found at the start; expected the jump's "
                         "time as a number or a parameter (latdyn.run takes the inputs' values as given)")


def _own_scene(source) -> Scene:
    """The scene the simulation runs, its own: a path or mapping is loaded; a loaded
    :class:`~latdyn.scene.loader.Scene` is loaded again from its mapping (its file name and its
    inputs' current values kept), so that the inputs the simulation sets are not those of the scene
    it was given (which another run or simulation may use)."""
    if not isinstance(source, Scene):
        return load_scene(source)
    scene = load_scene(copy.deepcopy(source.raw))
    scene.file = source.file
    for name, value in source.inputs.current().items():
        scene.inputs.set(name, value)
    return scene


class SimulationClosed(RuntimeError):
    """The simulation was closed, or its run failed: it takes no more steps."""


class Simulation:
    """A transient run of ``scene`` (a path, a mapping or a loaded scene, as for :func:`latdyn.run`)
    stepped from Python; ``out_dir``: the results folder, written as ``latdyn run`` writes it
    (None: nothing written, the rows kept for :meth:`close`'s Result); ``backend`` as for
    :func:`latdyn.run`.

    A scene that is not transient is refused (:class:`latdyn.SceneError` naming
    ``solve.analysis``), as any invalid scene is."""

    def __init__(self, scene, out_dir=None, backend: str = "auto"):
        self._wall0, self._compiled0 = time.perf_counter(), _compile_seconds()
        scene = _own_scene(scene)
        if scene.solve.analysis != "transient":
            raise SceneError(scene.file, "solve.analysis",
                             f"expected transient: a Simulation steps a transient run, and this scene's "
                             f"analysis is {scene.solve.analysis}")
        self.out_dir = out_dir
        self._prepared, self._probes, self._writer = open_run(scene, out_dir, backend)
        self._result: Result | None = None
        self._ended: str | None = None  # why the run can take no more steps
        #: the scene's inputs (latdyn.scene.inputs.Inputs: the values the laws read; empty without any)
        self._inputs = self._prepared.scene.inputs
        self._jumped = False  # an input changed since the last advance: the laws jumped at sim.t
        try:
            _refuse_jumps_timed_by_inputs(self._prepared.scene)
            write_linear_model_first(self._prepared, self._writer, out_dir)
            self._loop = start_transient(self._prepared, self._probes, self._writer)
        except BaseException as failure:
            self._fail(failure)
            raise

    # ------------------------------------------------------------------------- reading
    @property
    def t(self) -> float:
        """The time the run stands at (the last step's end; 0 before any advance)."""
        return float(self._loop.progress.state.t)

    @property
    def t_end(self) -> float:
        """``solve.t_end``: the latest time :meth:`advance_to` goes to."""
        return self._loop.control.t_end

    @property
    def input_names(self) -> list[str]:
        """The scene's ``inputs``, in file order."""
        return list(self._inputs.names)

    @property
    def probe_names(self) -> list[str]:
        """The scene's probes, in file order (the columns of probes.csv)."""
        return list(self._probes.names)

    def probes(self) -> dict[str, float]:
        """The probes' values at :attr:`t` (at t = 0 before any advance), by name in file order."""
        state = self._loop.progress.state
        return dict(zip(self._probes.names, (float(v) for v in self._probes.values(state))))

    def inputs(self) -> dict[str, float]:
        """The inputs' current values (the scene's until set), by name in file order."""
        return self._inputs.current()

    # ------------------------------------------------------------------------- driving
    def set_input(self, name: str, value: float) -> None:
        """Set the scene's input ``name`` to ``value`` from :attr:`t` on (held until set again).
        An unknown name, or a value that is not a finite number, is a ValueError naming it."""
        self._check_open("set_input")
        names = self.input_names
        if name not in names:
            known = ", ".join(names) if names else "none (the scene has no inputs)"
            raise ValueError(f"set_input: the scene has no input named {name!r}; its inputs: {known}")
        try:
            number = float(value)
        except (TypeError, ValueError):
            number = math.nan
        if not math.isfinite(number) or isinstance(value, bool):
            raise ValueError(f"set_input: input {name!r} takes a finite number, not {value!r}")
        if number != self._inputs[name]:
            self._refuse_a_moved_position(name, number)
            if not self._jumped:  # the stored energy under the laws before the first change at sim.t
                self._stored_before = self._loop.stored_energy(self._loop.progress.state)
            self._inputs.set(name, number)
            self._jumped = True

    def _refuse_a_moved_position(self, name: str, value: float) -> None:
        """A ValueError (the input left as it was) where setting input ``name`` to ``value`` at sim.t would
        move a prescribed position (a hinge's angle, a guide's slide, a body's motion that names it, as
        ``"u*t"`` does): a joint or body would jump a finite distance in no time (latdyn.run refuses such
        a law of t: latdyn.timeloop.jumps.prescribed_position_jump)."""
        t, old = self.t, self._inputs[name]
        laws = [(key, law) for key, law in prescribed_positions(self._loop.model.scene)
                if name in getattr(law, "input_names", ())]
        if not laws:
            return
        before = [float(law.value(t)) for _, law in laws]
        self._inputs.set(name, value)
        try:
            after = [float(law.value(t)) for _, law in laws]
        finally:
            self._inputs.set(name, old)
        for (key, _), a, b in zip(laws, before, after):
            if abs(b - a) > 1e-12 * (1.0 + abs(a) + abs(b)):
                raise ValueError(f"set_input: input {name!r} = {value!r} would move the prescribed position {key} "
                                 f"from {a:.9g} to {b:.9g} at t = {t:.9g} in no time (an infinite rate); expected a "
                                 "value that leaves it where it is (a prescribed rate that names the input, as "
                                 "'u*(t - t0)', moves on from there)")

    def advance_to(self, t: float) -> None:
        """Step the run from :attr:`t` to ``t`` (sim.t ≤ t ≤ ``solve.t_end``, within 1e-9 dt): steps
        of ``solve.dt`` on the run's grid, the one that would cross ``t`` shortened to land on it.
        A ``t`` outside that range is a ValueError; a failed step raises as ``latdyn.run`` does
        (:class:`latdyn.SolverError`), the result files then finished as a failed run's, and the
        simulation takes no more steps."""
        self._check_open("advance_to")
        try:
            target = float(t)
        except (TypeError, ValueError):
            raise ValueError(f"advance_to: t must be a number, not {t!r}") from None
        now, t_end = self.t, self.t_end
        slack = TIME_TOLERANCE * self._loop.control.dt
        if not math.isfinite(target) or target < now - slack:
            raise ValueError(f"advance_to({t!r}): the simulation is at t = {now!r} and steps only forward "
                             f"(t must be at least sim.t)")
        if target > t_end + slack:
            raise ValueError(f"advance_to({t!r}): past solve.t_end = {t_end!r}, where the scene's run ends")
        if self._jumped:  # the laws jumped at sim.t: the integrator goes on from there under them
            self._jumped = False
            self._loop.restart(self._stored_before)   # the jump's work (a spring's rest, a winch) counted
        if target <= now + slack:
            return
        try:
            self._loop.advance_to(min(target, t_end))
        except BaseException as failure:
            self._fail(failure)
            raise

    def close(self) -> Result:
        """Finish the run where it stands and return its :class:`~latdyn.results.result.Result` (the
        rows ``output.every`` asks for, and the state at :attr:`t` as the last row); with an
        ``out_dir``, the results folder is finished as ``latdyn run`` finishes it. ``summary.json``
        ``status`` is ``solved`` when the run reached ``solve.t_end``, else ``interrupted`` with an
        ``error`` that says where it was closed. A second call returns the same Result."""
        if self._result is not None:
            return self._result
        loop = self._loop
        reached = loop.control.finished(loop.progress)
        try:
            if not reached:
                loop.record_last()
            loop.end()
        except BaseException as failure:
            self._fail(failure)
            raise
        if reached:
            close_run(self._writer, self._wall0, self._compiled0)
        else:
            close_run(self._writer, self._wall0, self._compiled0, status="interrupted",
                      error=f"closed by Simulation.close() at t = {self.t!r}, before solve.t_end = {self.t_end!r}")
        self._ended = "it was closed"
        self._result = self._writer.result()
        return self._result

    def __enter__(self) -> "Simulation":
        return self

    def __exit__(self, *exc) -> bool:
        if self._result is None:
            self.close()
        return False

    # ------------------------------------------------------------------------- internals
    def _check_open(self, what: str) -> None:
        if self._ended is not None:
            raise SimulationClosed(f"{what}: the simulation takes no more steps: {self._ended}")

    def _fail(self, failure: BaseException) -> None:
        """The run failed or was interrupted: the result files finished as ``latdyn.run`` finishes a
        failed run's (status ``failed``, ``unbounded`` or ``interrupted``, the error said)."""
        if isinstance(failure, KeyboardInterrupt):
            status, error = "interrupted", "interrupted"
        else:
            status = "unbounded" if isinstance(failure, UnboundedError) else "failed"
            error = f"{type(failure).__name__}: {failure}"
        self._ended = f"its run {status}: {error}" if status != "interrupted" else "it was interrupted"
        if not self._writer.closed:
            loop = getattr(self, "_loop", None)
            if loop is not None and loop.progress is not None:
                try:
                    loop.end()
                except Exception:  # noqa: BLE001 - the failure itself matters more
                    pass
            close_run(self._writer, self._wall0, self._compiled0, status=status, error=error)
        self._result = self._writer.result()
