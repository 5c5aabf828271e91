"""Sampled controllers (SCENE.md ``controllers.NAME.rate``): the digital controller's cycle.

At each sample instant t = k/rate (k = 0, 1, …) of a controller, the time loop (which lands a step
on every instant: :class:`latdyn.timeloop.control.StepControl` puts the instants on its grid) reads
the probes at the accepted state and, controller by controller in file order,

    y_k = clip(output(t_k, sensors, S_k)),      S_{k+1} = S_k + EXPR(t_k, sensors, S_k) / rate,

then holds y_k (zero-order hold) until the next instant: the laws that name the controller read the
held value (:class:`latdyn.scene.inputs.ControllerOutputs`). A controller that reads an earlier
one sampled at the same instant reads its new value. The sample is a jump of the law between two
steps, like an event; the power of the loads is taken again after it, for the energy balance.

The outputs and states after each sample are what the progress carries
(:attr:`latdyn.timeloop.progress.TransientProgress.controller_memory`): a resumed run restores them.
The expressions are evaluated here, in Python, once per sample (``math`` lambdas: microseconds),
not inside the step.
"""
from __future__ import annotations

import numpy as np


class SampledControllers:
    """The scene's sampled controllers and the instants they sample at."""

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

    def sample(self, state, t: float, tolerance: float) -> bool:
        """The sample at ``t`` of the controllers due then, from the probes at ``state``; whether any was."""
        due = self.due(t, tolerance)
        if not due:
            return False
        values = dict(zip(self.probes.names, self.probes.values(state)))
        inputs = self.scene.inputs
        for c in due:
            def signal(name):
                if name in values:
                    return values[name]
                return inputs[name] if name in inputs else self.outputs[name]

            tk = round(t * c.rate) / c.rate
            own = [self.states[f"{c.name}.{s}"] for s in c.states]
            arguments = [tk, *(signal(n) for n in c.reads), *own]
            output, rates = c.functions()
            held = c.clip(float(output(*arguments)))
            steps = [float(f(*arguments)) / c.rate for f in rates]
            self.outputs.values[self.outputs.index(c.name)] = held
            for s, value, step in zip(c.states, own, steps):
                self.states.values[self.states.index(f"{c.name}.{s}")] = value + step
        return True

    def memory(self) -> np.ndarray:
        """A copy of every controller's output and state (what a checkpoint keeps)."""
        return np.concatenate([self.outputs.values, self.states.values]).copy()

    def restore(self, memory: np.ndarray | None) -> None:
        """Outputs and states as :meth:`memory` gave them."""
        if memory is None:
            return
        n = len(self.outputs.values)
        self.outputs.values[:] = memory[:n]
        self.states.values[:] = memory[n:]
