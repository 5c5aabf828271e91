"""Layer 4, what a run writes and reads back: the result files (``writer``: probes.csv, summary.json,
modes.csv), the state history (``state_history``), the ParaView output (``paraview``), safe file
writes (``files``), probe values (``probes``) and plots (``plot``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
