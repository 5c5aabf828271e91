"""Layer 5, analyses other than the time loop: static load stepping and modes (``static``), and the
checks of ``latdyn check`` (``check``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
