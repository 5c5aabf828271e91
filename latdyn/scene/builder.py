"""Scenes in code: a small builder for lattices (bodies, sections, beams, hinges, repeated bays).

The builder writes the same plain mapping a YAML scene file holds (``shared/SCENE.md``), so
what it builds is validated by :func:`latdyn.load_scene` like any file, and
:meth:`SceneBuilder.to_yaml` writes the file that loads to the same scene (same
``source_hash``). Nothing is checked while building: :meth:`SceneBuilder.build` runs the
one validation, and its :class:`~latdyn.errors.SceneError` names the key path of the
generated mapping (``beams.bay12_d.section``).

    from latdyn.scene.builder import SceneBuilder, hinge

    b = SceneBuilder("two-panel boom")
    b.section("panel", EA=1e7, EIy=1e3, EIz=1e3, GJ=1e3, rhoA=0.5)
    b.body("root", at=[0, 0, 0], fixed=True)
    b.body("knee", at=[1, 0, 0], mass=0.2)
    b.beam("p1", "root", "knee", "panel", elements=4)
    b.beam("p2", "knee", [0, 0.05, 0], "panel", elements=4,
           start=hinge([0, 0, -1], stiffness=2.0, rest_angle=3.6, lock_at="pi"))
    b.solve(t_end=2.0, dt=1e-3)
    scene = b.build()

:meth:`SceneBuilder.bays` repeats a bay: it calls ``bay(builder, i)`` for i = 0 … n − 1, the
function adding the bodies and beams of bay i (names made unique by the caller, e.g. with
``f"b{i}_top"``). Building is plain dictionary work (no NumPy per part), so 10⁴ elements
build and validate in well under a second (``examples/deployable_truss.py`` measures it).
"""
from __future__ import annotations

import copy
from typing import Any, Callable

from latdyn.scene.loader import Scene, load_scene

__all__ = ["SceneBuilder", "hinge", "clamped"]

#: The joint of a beam end that is clamped to its body (the default).
clamped = "clamped"


def _vector(value) -> list:
    """A 3-vector as a list of plain floats (NumPy arrays and tuples accepted); a component given
    as text (an expression of the scene's parameters, ``"L"``) stays text."""
    return [x if isinstance(x, str) else float(x) for x in value]


def _scalar(value):
    """A number as a plain float; an expression string or a table as given."""
    if isinstance(value, (str, dict)):
        return value
    return float(value)


def hinge(axis, *, stiffness=None, damping=None, torque=None, angle=None, lock_at=None, rest_angle=None,
          limits=None, restitution=None, contact=None, friction=None) -> dict:
    """A hinged beam end, ``{hinge: {...}}`` (SCENE.md HINGE and "Hinge additions"); ``None``
    leaves a key out (its default applies). ``contact`` and ``friction`` are mappings of their keys
    (``{"stiffness": 1e3, "exponent": 1.5}``, ``{"coulomb": 0.2}``; docs/contact.md)."""
    spec: dict[str, Any] = {"axis": _vector(axis)}
    for key, value in (("stiffness", stiffness), ("damping", damping), ("torque", torque), ("angle", angle),
                       ("lock_at", lock_at), ("rest_angle", rest_angle), ("restitution", restitution)):
        if value is not None:
            spec[key] = _scalar(value)
    if limits is not None:
        spec["limits"] = [_scalar(x) for x in limits]
    for key, value in (("contact", contact), ("friction", friction)):
        if value is not None:
            spec[key] = {name: _scalar(x) for name, x in dict(value).items()}
    return {"hinge": spec}


class SceneBuilder:
    """Builds a scene mapping part by part; :meth:`build` validates it into a :class:`Scene`."""

    def __init__(self, title: str = ""):
        self.data: dict[str, Any] = {"title": title, "sections": {}, "bodies": {}, "beams": {}}

    # -- parts -----------------------------------------------------------------------------
    def parameters(self, **values) -> "SceneBuilder":
        """Named numbers (SCENE.md ``parameters``): ``parameters(L=1.5, k=40)``; any number of the
        scene may then be an expression of them (``body("tip", at=["L", 0, 0])``)."""
        self.data.setdefault("parameters", {}).update({k: _scalar(v) for k, v in values.items()})
        return self

    def gravity(self, g) -> "SceneBuilder":
        self.data["gravity"] = _vector(g)
        return self

    def initial_velocity(self, linear=None, angular=None, about=None) -> "SceneBuilder":
        spec = {k: _vector(v) for k, v in (("linear", linear), ("angular", angular), ("about", about))
                if v is not None}
        self.data["initial_velocity"] = spec
        return self

    def section(self, name: str, *, EA, EIy, EIz, GJ, rhoA, **optional) -> str:
        """A cross-section; ``optional``: rhoIy, rhoIz, GAy, GAz (SCENE.md). Returns ``name``."""
        spec = {"EA": _scalar(EA), "EIy": _scalar(EIy), "EIz": _scalar(EIz), "GJ": _scalar(GJ), "rhoA": _scalar(rhoA)}
        spec.update((k, _scalar(v)) for k, v in optional.items() if v is not None)
        self.data["sections"][name] = spec
        return name

    def body(self, name: str, at, *, mass=None, com=None, inertia=None, fixed: bool = False,
             translation=None, rotation=None) -> str:
        """A joint body. ``translation``: [fx, fy, fz] (prescribed displacement); ``rotation``:
        ``(axis, angle)`` (prescribed rotation). Returns ``name``."""
        spec: dict[str, Any] = {"at": _vector(at)}
        if mass is not None:
            spec["mass"] = _scalar(mass)
        if com is not None:
            spec["com"] = _vector(com)
        if inertia is not None:
            spec["inertia"] = [_vector(row) for row in inertia] \
                if hasattr(inertia[0], "__len__") and not isinstance(inertia[0], str) \
                else _vector(inertia)
        if fixed:
            spec["fixed"] = True
        motion = {}
        if translation is not None:
            motion["translation"] = [_scalar(x) for x in translation]
        if rotation is not None:
            axis, angle = rotation
            motion["rotation"] = {"axis": _vector(axis), "angle": _scalar(angle)}
        if motion:
            spec["motion"] = motion
        self.data["bodies"][name] = spec
        return name

    def beam(self, name: str, from_, to, section: str, *, elements: int | None = None, y_axis=None,
             start=None, end=None, rigid: bool | None = None) -> str:
        """A beam from ``from_`` to ``to``: each a body name, ``(body, offset)`` (a grid point at an
        offset in body axes) or a point [x, y, z] (a free end). ``start``/``end``: :data:`clamped`
        (default) or :func:`hinge`. Returns ``name``."""
        spec: dict[str, Any] = {"from": self._end(from_), "to": self._end(to), "section": section}
        if elements is not None:
            spec["elements"] = int(elements)
        if y_axis is not None:
            spec["y_axis"] = _vector(y_axis)
        if start is not None:
            spec["start"] = copy.deepcopy(start)
        if end is not None:
            spec["end"] = copy.deepcopy(end)
        if rigid is not None:
            spec["rigid"] = bool(rigid)
        self.data["beams"][name] = spec
        return name

    @staticmethod
    def _end(value):
        if isinstance(value, str):
            return value
        if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], str):
            return {"body": value[0], "offset": _vector(value[1])}
        return _vector(value)

    def bays(self, count: int, bay: Callable[["SceneBuilder", int], None]) -> "SceneBuilder":
        """Repeat a bay: ``bay(self, i)`` for i = 0 … count − 1."""
        for i in range(count):
            bay(self, i)
        return self

    def load(self, at: str, *, force=None, moment=None, frame: str | None = None) -> "SceneBuilder":
        spec: dict[str, Any] = {"at": at}
        if force is not None:
            spec["force"] = [_scalar(x) for x in force]
        if moment is not None:
            spec["moment"] = [_scalar(x) for x in moment]
        if frame is not None:
            spec["frame"] = frame
        self.data.setdefault("loads", []).append(spec)
        return self

    def probe(self, name: str, **spec) -> "SceneBuilder":
        """A probe, as in SCENE.md: ``probe("tip", point="arm.end", quantity="position", component="y")``."""
        self.data.setdefault("output", {}).setdefault("probes", {})[name] = dict(spec)
        return self

    def solve(self, **spec) -> "SceneBuilder":
        """The ``solve`` mapping: ``solve(t_end=2, dt=1e-3)``, ``solve(analysis="modes", count=6)``."""
        self.data["solve"] = dict(spec)
        return self

    def output(self, every=None, paraview_every=None) -> "SceneBuilder":
        """``output.every`` and ``output.paraview_every`` (SCENE.md; 0: no ParaView frames)."""
        for key, value in (("every", every), ("paraview_every", paraview_every)):
            if value is not None:
                self.data.setdefault("output", {})[key] = float(value)
        return self

    # -- results -----------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """The scene mapping (a deep copy), as a YAML file would hold it."""
        return copy.deepcopy(self.data)

    def build(self) -> Scene:
        """Validate into a :class:`Scene` (:class:`~latdyn.errors.SceneError` on a bad part)."""
        return load_scene(self.data)

    def to_yaml(self, path=None) -> str:
        """The scene as YAML text (block style, keys in the order given); written to ``path`` if given."""
        import yaml

        text = yaml.safe_dump(self.data, sort_keys=False, default_flow_style=None, width=120)
        if path is not None:
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
        return text
