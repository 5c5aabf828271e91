"""Records: ``dataclasses.dataclass`` with the same ``__repr__``, ``__eq__`` and ``__hash__``, made without ``exec``.

On Python 3.11 ``dataclass`` writes each method it adds as source text and compiles it (``exec``): a class
costs three compiles (``__init__``, ``__repr__``, ``__eq__``) and a frozen one six; for the 40 classes a
``latdyn run`` imports that was most of the 12 ms their processing took in a fresh process
(docs/performance.md, "Twelfth pass: latdyn's own part of the lattice process"). :func:`record` lets
``dataclass`` write ``__init__`` (and a frozen class's ``__setattr__`` and ``__delattr__``) as before and gives the
class a ``__repr__``, an ``__eq__`` and, where ``dataclass`` would, a ``__hash__`` that do what the generated
ones do, from the class's field names, without compiling anything:

- ``repr``: ``QualName(a=..., b=...)`` over the fields with ``repr=True``, ``...`` for a record met again
  inside its own repr (on the same thread), as ``dataclasses`` does;
- ``==``: ``NotImplemented`` unless both are of the very same class, else the tuples of the fields with
  ``compare=True`` compared;
- ``hash``: unhashable (``__hash__ = None``) unless frozen; a frozen record hashes the tuple of the fields that
  ``dataclass`` would hash (``hash=`` or else ``compare=``);
- a method the class body writes itself is kept, as ``dataclass`` keeps it; ``__dataclass_params__`` says
  ``repr`` and ``eq``, as for ``@dataclass``.

``dataclasses.fields``, ``replace``, ``asdict``, pickling and ``inspect.signature`` are those of the
dataclass. Only what ``@dataclass`` and ``@dataclass(frozen=True)`` take is accepted (``frozen``).
"""
from __future__ import annotations

import dataclasses
from _thread import get_ident

__all__ = ["record"]


def record(cls=None, /, *, frozen: bool = False):
    """``@record`` for ``@dataclass``, ``@record(frozen=True)`` for ``@dataclass(frozen=True)``."""
    def wrap(cls):
        return _record(cls, frozen)

    return wrap if cls is None else wrap(cls)


def _record(cls, frozen: bool):
    body = dict(cls.__dict__)
    class_hash = body.get("__hash__", dataclasses.MISSING)
    explicit_hash = not (class_hash is dataclasses.MISSING or (class_hash is None and "__eq__" in body))
    cls = dataclasses.dataclass(cls, repr=False, eq=False, frozen=frozen)
    fields = dataclasses.fields(cls)
    if "__repr__" not in body:
        _method(cls, "__repr__", _repr_of(tuple(f.name for f in fields if f.repr)))
    if "__eq__" not in body:
        _method(cls, "__eq__", _eq_of(tuple(f.name for f in fields if f.compare)))
    if not explicit_hash:
        if frozen:
            _method(cls, "__hash__", _hash_of(tuple(
                f.name for f in fields if (f.compare if f.hash is None else f.hash))))
        else:
            cls.__hash__ = None
    params = cls.__dataclass_params__
    params.repr = params.eq = True
    return cls


def _method(cls, name, function) -> None:
    function.__qualname__ = f"{cls.__qualname__}.{name}"
    setattr(cls, name, function)


def _repr_of(names: tuple):
    running = set()

    def __repr__(self):
        key = id(self), get_ident()
        if key in running:
            return "..."
        running.add(key)
        try:
            return self.__class__.__qualname__ + "(" + ", ".join(
                f"{name}={getattr(self, name)!r}" for name in names) + ")"
        finally:
            running.discard(key)

    return __repr__


def _eq_of(names: tuple):
    def __eq__(self, other):
        if other.__class__ is self.__class__:
            return tuple(getattr(self, name) for name in names) == tuple(getattr(other, name) for name in names)
        return NotImplemented

    return __eq__


def _hash_of(names: tuple):
    def __hash__(self):
        return hash(tuple(getattr(self, name) for name in names))

    return __hash__
