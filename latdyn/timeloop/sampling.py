"""Sampled controllers (SCENE.md ``controllers.NAME.rate``): the digital controller's cycle.

At each sample instant t = k/rate (k = 0, 1, …) of a controller, the time loop (which lands a step
on every instant: :class:`latdyn.timeloop.control.StepControl` puts the instants on its grid) reads
the probes at the accepted state and, controller by controller in file order,

    y_k = clip(output(t_k, sensors, S_k)),      S_{k+1} = S_k + EXPR(t_k, sensors, S_k) / rate,

then holds y_k (zero-order hold) until the next instant: the laws that name the controller read the
held value (:class:`latdyn.scene.inputs.ControllerOutputs`). A controller that reads an earlier
one sampled at the same instant (by its name, or through a probe of its output) reads its new value.
The sample is a jump of the law between two steps, like an event: the accelerations restart from
those consistent with the new outputs and the power of the loads is taken again after it, for the
energy balance.

The sample is compiled like the laws: each controller's output and state rates are a generated
kernel of the scene's laws unit (codegen/laws.py ``latdyn_sampled_laws``), its sensors the C probe
evaluation of the continuous controllers (csrc/evaluate.c ``sensor_value``), the cycle
``latdyn_sample_controllers`` (csrc/sampling.c). The compiled loop of steps takes it at every
instant without returning to Python, and the restart after it too where every direction has an
inertia that does not depend on the state (v̇ ← v̇ − M⁻¹r, with rigid links and guides on the minimum
coordinates with Pᵀ M P: :func:`latdyn.step.integrators.consistent_acceleration` with an all-massive
split, :meth:`latdyn.step.compiled.CompiledGeneralizedAlpha.restarts_natively`; the steps from Python restart
there with the same C, :meth:`~latdyn.step.compiled.CompiledGeneralizedAlpha.restart_after_sample`); otherwise (directions
without inertia: 3D beams without rotary inertia) it returns after the sample and the time loop
restarts from Python with the inertia split. A probe no C sensor evaluates (energy, momentum, a joint's reaction) is
handed in from Python (:meth:`latdyn.assembly.native_model.NativeModel.sample`): the loop of steps then stops
on the instants and the time loop calls the same cycle there.

The outputs and states after each sample are what the progress carries
(:attr:`latdyn.timeloop.progress.TransientProgress.controller_memory`): a resumed run restores them.
"""
from __future__ import annotations

import numpy as np

from latdyn.assembly.control import state_rates


class SampledControllers:
    """The scene's sampled controllers and the instants they sample at; the sample is the compiled
    cycle of the native model (``probes.assembler``'s, module docstring)."""

    def __init__(self, scene, probes):
        self.scene, self.probes = scene, probes
        self.controllers = [c for c in scene.controllers.values() if c.sampled]
        self.outputs, self.states = scene.controller_outputs, scene.controller_states

    def __bool__(self) -> bool:
        return bool(self.controllers)

    def instants(self, t_end: float) -> np.ndarray:
        """Every sample instant in (0, t_end] of every sampled controller, sorted (k/rate, computed)."""
        times = [k / c.rate for c in self.controllers for k in range(1, int(np.floor(t_end * c.rate * (1 + 1e-12))) + 1)]
        return np.unique(np.array(times, dtype=float))

    def start(self, state, tolerance: float) -> None:
        """Outputs and states as the scene gives them, then the sample at t = 0."""
        self.outputs.reset()
        self.states.reset()
        self.sample(state, 0.0, tolerance)

    def due(self, t: float, tolerance: float) -> list:
        """The controllers whose sample instant ``t`` is (within ``tolerance``)."""
        return [c for c in self.controllers if abs(round(t * c.rate) / c.rate - t) <= tolerance]

    @property
    def in_loop(self) -> bool:
        """Whether the loop of steps in C can sample (every probe read has a C sensor)."""
        return not self.probes.assembler.native().provided

    def sample(self, state, t: float, tolerance: float) -> bool:
        """The sample at ``t`` of the controllers due then, from the probes at ``state``
        (``latdyn_sample_controllers``); whether any was."""
        if not self.due(t, tolerance):
            return False
        native = self.probes.assembler.native()
        provided = None
        if native.provided:  # probes without a C sensor: their values from the probe set
            values = dict(zip(self.probes.names, self.probes.values(state)))
            provided = {name: values[name] for _, name in native.provided}
        return native.sample(state, t, tolerance, provided) > 0

    def memory(self) -> np.ndarray:
        """A copy of every controller's output and state (what a checkpoint keeps: :func:`controller_memory`)."""
        return controller_memory(self.scene)

    def restore(self, memory: np.ndarray | None) -> None:
        """Outputs and states as :meth:`memory` gave them."""
        restore_controller_memory(self.scene, memory)


def controller_memory(scene) -> np.ndarray | None:
    """A copy of every controller's output and state and of the states' rates dS/dt (those of the
    continuous controllers' states: :func:`latdyn.assembly.control.state_rates`), what a checkpoint
    keeps; None for a scene without controllers."""
    if not getattr(scene, "controllers", None):
        return None
    return np.concatenate([scene.controller_outputs.values, scene.controller_states.values, state_rates(scene)])


def restore_controller_memory(scene, memory: np.ndarray | None) -> None:
    """Outputs, states and rates as :func:`controller_memory` gave them (a checkpoint of a run without
    the rates, from before the states of continuous controllers: outputs and states)."""
    if memory is None:
        return
    outputs, states = scene.controller_outputs.values, scene.controller_states.values
    n, p = len(outputs), len(states)
    outputs[:] = memory[:n]
    states[:] = memory[n:n + p]
    if len(memory) >= n + 2 * p:
        state_rates(scene)[:] = memory[n + p:n + 2 * p]
