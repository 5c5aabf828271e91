"""Layer 5, the transient analysis (``transient``: the integrator, the loop started), its loop over
rows and steps (``loop``), the step sizes on the time grid (``control``), its events (latches, hinge
stops: ``events``), the state it carries from step to step (``progress``) and its checkpoints
(``checkpoint``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
