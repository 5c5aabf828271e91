"""Layer 6, analyses besides the time loop: static paths (``continuation``: load control, arc length,
displacement control), linearisation about a state (``linearise``: modes, buckling, linear models),
what moves in a scene (``moving``) and the checks of ``latdyn check`` with the modes at rest they use
(``check``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
