"""Layer 3, one evaluation of the equations of motion: the model as the C library reads it and its one
evaluation (``native_model``, ``library``, ``csrc/evaluate.c``; the scene's laws in ``compiled_laws``),
state and the residual, mass, damping and stiffness matrices (``assembler``, ``evaluation``), rigid
links reduced onto minimum coordinates (``linked``), the one LU factorization of every linear solve
(``factorization``, ``csrc/factorization.c``; the sparse LU's analysis in ``sparse_lu``), and the prepared run — scene, model, assembler,
initial state (``prepare``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
