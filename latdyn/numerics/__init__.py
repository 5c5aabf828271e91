"""Layer 0, numerics without physics: SO(3) maps (``so3``), linear solves and their policy (``linalg``),
the directions without inertia (``inertia``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
