"""What each probe of a scene measures, in words and units, for plot axes
(``summary.json`` ``probe_labels``: ``{probe name: label}``, read by ``latdyn plot``).

Units are those of SI, which every shipped scene uses (SCENE.md: any consistent set is
allowed; a scene in other units reads the labels in its own): lengths m, times s, angles rad,
forces N, moments N·m, energies J.
"""
from __future__ import annotations

__all__ = ["probe_label", "probe_labels"]

_POINT_UNITS = {"position": "m", "displacement": "m", "velocity": "m/s"}
_HINGE = {"angle": ("hinge angle", "rad"), "rate": ("hinge rate", "rad/s"),
          "torque": ("torque the hinge applies", "N·m")}
_GUIDE = {"position": ("slide", "m"), "rate": ("slide rate", "m/s"), "force": ("force the guide applies", "N")}
_ENERGY = {"kinetic": "kinetic energy", "strain": "strain energy", "potential": "potential energy",
           "external_work": "external work", "total": "total energy",
           "dissipated": "declared dissipated energy (impacts, latches, hinge dampers)"}
_MOMENTUM = {"linear": ("linear momentum", "kg·m/s"), "angular": ("angular momentum about the origin", "kg·m²/s")}
_SECTION = {"axial_force": ("axial force", "N"), "torque": ("torque", "N·m"),
            "moment_y": ("bending moment about local y", "N·m"), "moment_z": ("bending moment about local z", "N·m")}


def probe_label(probe) -> str:
    """``tip_y: position y of arm.end in hub axes (m)`` for a probe of the scene
    (:class:`latdyn.scene.loader.Probe`)."""
    kind, quantity = probe.kind, probe.quantity
    if kind == "point":
        what = f"|{quantity}|" if probe.component == "norm" else f"{quantity} {probe.component}"
        where = "" if probe.frame == "global" else f" in {probe.frame} axes"
        text, unit = f"{what} of {probe.point.text}{where}", _POINT_UNITS[quantity]
    elif kind == "hinge":
        words, unit = _HINGE[quantity]
        text = f"{words} of {probe.beam}.{probe.end}"
    elif kind == "guide":
        words, unit = _GUIDE[quantity]
        text = f"{words} of the guide of {probe.body}"
    elif kind == "energy":
        text, unit = _ENERGY[quantity], "J"
    elif kind == "momentum":
        words, unit = _MOMENTUM[quantity]
        text = f"{words}, {probe.component}"
    elif kind == "element":
        words, unit = _SECTION[quantity]
        text = f"{words} in {probe.beam}.element[{probe.element}]"
    elif kind == "controller":
        text, unit = (f"output of controller {probe.controller}" if probe.state is None
                      else f"state {probe.state} of controller {probe.controller}"), "its own unit"
    elif kind == "cable":
        text, unit = (f"tension of cable {probe.beam} (its first element)", "N") if quantity == "tension" \
            else (f"length of cable {probe.beam} along it", "m")
    else:  # a probe kind added later without a label here: its name says what it is
        return probe.name
    return f"{probe.name}: {text} ({unit})"


def probe_labels(probes) -> dict:
    """``{name: probe_label(probe)}`` for the scene's probes, in their order."""
    return {p.name: probe_label(p) for p in probes}
