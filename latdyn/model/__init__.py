"""Layer 2, the model: a scene turned into minimum coordinates — nodes, elements, hinges, their numbering
(``model``), rigid links as dependent nodes (``links``), the restriction of planar scenes (``planar``), and
the generated element kernels of its formulation (``kernels``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
