"""Layer 4, one time step: the generalized-α family and the explicit method driven from Python
(``integrators``), and the Newton iteration and loop of steps in C (``compiled``, whose C source is
``latdyn/assembly/csrc/newton_step.c``; its matrix is held and factorized by
:class:`latdyn.assembly.factorization.Factorization`).
Every evaluation is the native one of :mod:`latdyn.assembly.native_model`.

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
