"""The keys at which a named parameter is used, by what it is (docs/parameters.md, "Sensitivities"):
a load component, a section value, a body's mass, centre of mass or inertia, the initial velocity, a
guide's, cable's, hinge's or compliant stop's law, a controller's output or state rate. Each pattern's
groups name the parts the derivative needs; the tables map a key's word to its slot in the generated
kernels' blocks; whether a scene prescribes a motion (:func:`prescribed_motion`), has events the sensitivities land
on (:func:`has_events`) and which of its laws name a controller (:func:`laws_naming`). Read by every sensitivity module (latdyn/analyses/sensitivities.py and those it
calls), so kept below them all."""
from __future__ import annotations

import re
from dataclasses import fields, is_dataclass

LOAD_KEY = re.compile(r"^loads\[(?P<load>\d+)\]\.(?P<kind>force|moment)\[(?P<axis>[0-2])\]$")
SECTION_KEY = re.compile(r"^sections\.(?P<section>[^.]+)\.(?P<value>EA|EIy|EIz|GJ|rhoA|rhoIy|rhoIz|GAy|GAz)$")
#: the section block's columns (codegen/conventions.py: L0 EA EIy EIz GJ rhoA rhoIy rhoIz 1/GAy 1/GAz); GAy and
#: GAz enter through their compliances 1/GAy, 1/GAz (∂(1/GA)/∂p = −(1/GA)² ∂GA/∂p)
SECTION_COLUMN = {"EA": 1, "EIy": 2, "EIz": 3, "GJ": 4, "rhoA": 5, "rhoIy": 6, "rhoIz": 7, "GAy": 8, "GAz": 9}
BODY_KEY = re.compile(r"^bodies\.(?P<body>[^.]+)\.(?:(?P<mass>mass)|com\[(?P<com>[0-2])\]|"
                       r"(?P<inertia>inertia)\[(?P<row>[0-2])\](?:\[(?P<col>[0-2])\])?)$")
#: a component of the rigid motion at t = 0 (transient runs: the velocities are affine in it at a fixed ``about``)
INITIAL_VELOCITY_KEY = re.compile(r"^initial_velocity\.(?P<kind>linear|angular)\[(?P<axis>[0-2])\]$")
#: a guide's laws (transient runs), read as the hinge laws they are on the slide s (force: the torque's place)
GUIDE_KEY = re.compile(r"^bodies\.(?P<body>[^.]+)\.guide\.(?P<law>stiffness|damping|force|rest)$")
GUIDE_LAW = {"force": "torque", "rest": "rest_angle"}
#: a cable's axial stiffness, damping and rest length (transient runs: latdyn/analyses/transient_sensitivities.py)
CABLE_KEY = re.compile(r"^cables\.(?P<cable>[^.]+)\.(?P<value>EA|damping|rest_length|rhoA)$")
HINGE_KEY = re.compile(r"^beams\.(?P<beam>.+)\.(?P<end>start|end)\.hinge\.(?P<law>stiffness|damping|torque|rest_angle)$")
#: a compliant stop's law (transient runs: ∂f/∂(k, n, c) from the generated ``contact_force_D_law``)
CONTACT_KEY = re.compile(r"^beams\.(?P<beam>.+)\.(?P<end>start|end)\.hinge\.contact\."
                          r"(?P<law>stiffness|exponent|damping)$")
#: the slots of the law in the generated kernel's output
CONTACT_SLOT = {"stiffness": 0, "exponent": 1, "damping": 2}
#: a guide's compliant stops' law (transient runs: as a hinge's, on its slide)
GUIDE_CONTACT_KEY = re.compile(r"^bodies\.(?P<body>[^.]+)\.guide\.contact\.(?P<law>stiffness|exponent|damping)$")
#: a hinge's or guide's friction law (transient runs: ∂f/∂(F_c, F_s, 1/v_s, c_v, v₀) from the generated
#: ``friction_force_D_law`` while the joint slips)
FRICTION_KEY = re.compile(r"^(?:beams\.(?P<beam>.+)\.(?P<end>start|end)\.hinge|bodies\.(?P<body>[^.]+)\.guide)"
                          r"\.friction\.(?P<law>coulomb|static|stribeck_rate|viscous|stick_rate)$")
#: the slots of the friction law in the generated kernel's output
FRICTION_SLOT = {"coulomb": 0, "static": 1, "stribeck_rate": 2, "viscous": 3, "stick_rate": 4}


def joint_law(key: str):
    """(beam or guided body, end or "guide", "contact" or "friction", its slot in the generated kernel's output)
    of a compliant stop's or friction's law at ``key`` (a hinge's or a guide's), or None."""
    for pattern, kind, slots in ((CONTACT_KEY, "contact", CONTACT_SLOT), (GUIDE_CONTACT_KEY, "contact", CONTACT_SLOT),
                                 (FRICTION_KEY, "friction", FRICTION_SLOT)):
        match = pattern.match(key)
        if match:
            groups = match.groupdict()
            beam, end = (groups["beam"], groups["end"]) if groups.get("beam") else (groups["body"], "guide")
            return beam, end, kind, slots[groups["law"]]
    return None
#: a continuous controller's output law (transient runs: ∂y/∂p through the sensors' values, ControllerTerms)
CONTROLLER_KEY = re.compile(r"^controllers\.(?P<name>[^.]+)\.(?:output|states\.(?P<state>[^.]+))$")


def prescribed_motion(scene) -> bool:
    """Whether a body's translation or rotation, a hinge's angle or a guide's slide is prescribed in ``scene``."""
    return any(body.prescribed or (body.guide is not None and body.guide.position is not None)
               for body in scene.bodies.values()) or any(hinge.angle is not None for _, _, hinge in scene.hinges)


def has_events(scene) -> bool:
    """Whether ``scene`` has anything whose time the sensitivities land on: a hinge's or guide's latch or
    stops (rigid or compliant: the onset), a cable (its slack/taut changes)."""
    joints = [hinge for _, _, hinge in scene.hinges] + [b.guide for b in scene.bodies.values() if b.guide is not None]
    return bool(scene.cables) or any(j.lock_at is not None or j.limits is not None for j in joints)


def laws_naming(scene, controllers: set) -> dict[str, list]:
    """The scene's parsed laws (hinge, guide and cable laws, load components, prescribed motions:
    latdyn.scene.expressions laws, each carrying the key path it was read at) that name one of
    ``controllers``, by key path -> the controllers named: the names the parser found
    (``input_names``), never the text's words (a controller ``e5`` is not read by ``"2e5*k"``)."""
    found, seen, pending = {}, set(), [scene]
    while pending:
        item = pending.pop()
        if id(item) in seen:
            continue
        seen.add(id(item))
        if hasattr(item, "input_names") and hasattr(item, "key"):
            named = [n for n in item.input_names if n in controllers]
            if named and not item.key.startswith("controllers."):
                found[item.key] = named
        elif is_dataclass(item) and not isinstance(item, type):
            pending.extend(getattr(item, f.name) for f in fields(item))
        elif isinstance(item, (list, tuple)):
            pending.extend(item)
        elif isinstance(item, dict):
            pending.extend(item.values())
    return found
