"""Layer 4, one time step: generalized-α and the explicit method in Python (``integrators``), the compiled
step and loop (``compiled``, ``library`` — the native boundary — and ``csrc/``), the sparse LU
(``sparse_lu``) and the scene's compiled laws (``compiled_laws``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
