"""Layer 1, the scene: a YAML file read and validated into a :class:`~latdyn.scene.loader.Scene`
(``loader``), its functions of time and hinge laws (``expressions``), and scenes built in code (``builder``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
