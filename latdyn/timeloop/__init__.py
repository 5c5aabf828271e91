"""Layer 5, the transient time loop (``transient``), its events (latches, hinge stops: ``events``), the
state it carries from step to step (``progress``) and its checkpoints (``checkpoint``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
