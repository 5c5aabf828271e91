"""The keys at which a named parameter is used, by what it is (docs/parameters.md, "Sensitivities"):
a load component, a section value, a body's mass, centre of mass or inertia, the initial velocity, a
guide's, cable's, hinge's or compliant stop's law, a controller's output or state rate. Each pattern's
groups name the parts the derivative needs; the tables map a key's word to its slot in the generated
kernels' blocks. Read by every sensitivity module (latdyn/analyses/sensitivities.py and those it
calls), so kept below them all."""
from __future__ import annotations

import re

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
#: a continuous controller's output law (transient runs: ∂y/∂p through the sensors' values, ControllerTerms)
CONTROLLER_KEY = re.compile(r"^controllers\.(?P<name>[^.]+)\.(?:output|states\.(?P<state>[^.]+))$")
