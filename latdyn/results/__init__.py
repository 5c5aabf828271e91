"""Layer 4, what a run writes and reads back: the result files (``writer``, composing one module per
output: ``probes_csv``, ``summary``, ``modes_csv``, the state history ``state_history`` and the
ParaView output ``paraview``), a results folder read back (``result``), safe file writes
(``files``), the progress bar (``progress``), probe values (``probes``) and plots (``plot``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
