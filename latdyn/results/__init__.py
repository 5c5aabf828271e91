"""Layer 4, what a run writes and reads back: the result files (``writer``), probe values (``probes``),
the ParaView output (``paraview``) and plots (``plot``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
