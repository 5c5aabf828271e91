"""Layer 0, numerics: SO(3) maps (``so3``, the exponential from the generated ``so3_exp``), linear solves and their policy (``linalg``),
the directions without inertia (``inertia``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
