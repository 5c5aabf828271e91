"""Exceptions that the command line turns into exit statuses (SCENE.md), and how a bad value is shown."""
from __future__ import annotations

import math
import reprlib


class _ShortRepr(reprlib.Repr):
    """``repr`` cut to a readable length, safe for any value a scene file can hold.

    Nested and shared containers (YAML aliases can make a few lines of a file
    expand to 10⁹ items) are shown to a few levels and items, and integers too
    long for ``repr`` (Python refuses more than 4300 digits) by their size.
    """

    def __init__(self):
        super().__init__()
        self.maxlevel, self.maxlist, self.maxtuple, self.maxdict = 3, 6, 6, 6
        self.maxset = self.maxfrozenset = 6
        self.maxstring = self.maxlong = self.maxother = 80

    def repr_int(self, x, level):
        if x.bit_length() > 256:
            return f"<an integer of about {math.floor(x.bit_length() * math.log10(2)) + 1} digits>"
        return super().repr_int(x, level)


_SHORT_REPR = _ShortRepr()


def show_value(value) -> str:
    """A bounded description of a (possibly bad) value for an error message."""
    return "nothing" if value is None else _SHORT_REPR.repr(value)


class SceneError(ValueError):
    """An invalid scene: exit status 2, message on stderr, nothing solved.

    The message always names the file, the key path (``beams.arm.section``)
    and what was expected there.
    """

    def __init__(self, file: str | None, key: str, expected: str):
        self.file = file or "<scene>"
        self.key = key
        self.expected = expected
        super().__init__(f"{self.file}: {key}: {expected}")


class SolverError(RuntimeError):
    """The solver failed: exit status 1; what was recorded stays readable."""

    def __init__(self, message: str, diagnosis: str = ""):
        self.diagnosis = diagnosis
        super().__init__(message if not diagnosis else f"{message}\n{diagnosis}")


class UnboundedError(SolverError):
    """The run's energy balance broke (docs/energy.md): the integrator created more energy than the
    threshold allows by time ``t``. Exit status 1, ``summary.json`` status ``unbounded``; what was
    recorded up to then (the row at ``t`` included) stays readable."""

    def __init__(self, message: str, t: float):
        self.t = t
        super().__init__(message)


class MissingExtra(ImportError):
    """A feature needs a package of an optional extra that is not installed; the message
    names the ``pip install`` that brings it (exit status 1 on the command line)."""


def require(extra: str, purpose: str, *modules: str):
    """Import ``modules`` (the packages of ``latdyn[extra]``) for ``purpose``, or raise
    :class:`MissingExtra` naming the extra; returns the modules."""
    import importlib

    loaded = []
    for name in modules:
        try:
            loaded.append(importlib.import_module(name))
        except ImportError as error:
            raise MissingExtra(f"{purpose} needs {name}, which is not installed: "
                               f"pip install \"latdyn[{extra}]\" ({error})") from None
    return loaded[0] if len(loaded) == 1 else tuple(loaded)


class ResultsError(ValueError):
    """A results folder that is missing or cannot be read (the CLI exits 2)."""
