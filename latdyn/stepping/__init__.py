"""Stepping a transient run from outside its loop: :class:`~latdyn.stepping.simulation.Simulation`
(advance to a time, read the probes, set inputs, go on) and the FMI 2.0 co-simulation FMU built
on it (:mod:`latdyn.stepping.fmu`, ``latdyn fmu``). See docs/stepping.md."""
