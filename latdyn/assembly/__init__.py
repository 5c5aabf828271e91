"""Layer 3, one evaluation of the equations of motion: state, residual, and the mass, damping and
stiffness matrices (``assembler``), rigid links reduced onto minimum coordinates (``linked``), and the
prepared run — scene, model, assembler, initial state (``prepare``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
