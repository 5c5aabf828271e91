"""A scene's inputs: named external signals (SCENE.md ``inputs: {NAME: number, …}``).

An input is a name any expression of the scene may use (a hinge ``torque``, a load component, a
hinge law) as it uses ``t``. In ``latdyn run`` each keeps the value the scene gives it; from
outside (Python stepping, an FMU, a controller written elsewhere) it is set between steps with
:meth:`Inputs.set`, and the next step sees the new value: the step's laws read
:attr:`Inputs.values` itself, in C (the compiled laws hold its address, codegen/laws.py
``latdyn_inputs``) and in Python (:class:`latdyn.scene.expressions.TimeFunction` and
:class:`~latdyn.scene.expressions.HingeLaw` evaluate with the current values). Between two
settings an input is constant: its time derivatives are zero.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["Signals", "Inputs", "ControllerOutputs"]


class Signals:
    """Named values that the scene's laws read by name: ``values`` is the one array every law reads
    (float64, one entry per name, never reallocated); ``initial`` the values at the start."""

    def __init__(self, initial: dict[str, float] | None = None):
        self.initial = {str(name): float(value) for name, value in (initial or {}).items()}
        self.names = tuple(self.initial)
        self.values = np.array([self.initial[name] for name in self.names] or [0.0], dtype=np.float64)
        self._index = {name: k for k, name in enumerate(self.names)}

    def index(self, name: str) -> int:
        """The position of input ``name`` in :attr:`values`; KeyError naming it and the known inputs."""
        try:
            return self._index[name]
        except (KeyError, TypeError):
            known = ", ".join(self.names) if self.names else "none: the scene has no inputs"
            raise KeyError(f"unknown input {name!r}; the scene's inputs are: {known}") from None

    def set(self, name: str, value: float) -> None:
        """Give input ``name`` the value ``value`` from now on (the next step uses it).
        KeyError for a name the scene does not declare, ValueError for a value that is not a finite number."""
        k = self.index(name)
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"input {name!r}: expected a finite number, got {value!r}") from None
        if not math.isfinite(number):
            raise ValueError(f"input {name!r}: expected a finite number, got {value!r}")
        self.values[k] = number

    def __getitem__(self, name: str) -> float:
        return float(self.values[self.index(name)])

    def __contains__(self, name) -> bool:
        return name in self._index

    def __iter__(self):
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)

    def current(self) -> dict[str, float]:
        """Each input's current value, by name."""
        return {name: float(self.values[k]) for k, name in enumerate(self.names)}

    def reset(self) -> None:
        """Every input back to the value the scene gives it."""
        for k, name in enumerate(self.names):
            self.values[k] = self.initial[name]

    def __repr__(self):
        return f"{type(self).__name__}({self.current()!r})"


class Inputs(Signals):
    """The scene's inputs in file order (``inputs: {NAME: number}``); ``initial``: the values the
    scene file gives, :meth:`set` from outside."""


class ControllerOutputs(Signals):
    """The current output of each of the scene's controllers, in file order (latdyn.scene.controllers):
    the held value of a sampled one, the last evaluated value of a continuous one. The time loop
    writes them; a law that names a controller reads them (``latdyn_controllers`` in the compiled laws)."""
