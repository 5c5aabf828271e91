"""Layer 7, studies over many runs (STUDY.md): the runner (``runner``), one case (``case``), Dask
(``cluster``) and the study's pictures (``plots``).

Layers: see docs/architecture.md; tests/test_layers.py holds them."""
