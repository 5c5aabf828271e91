"""SHA-256 for the kernel cache's keys and the scene's hash, without OpenSSL where Python has its own.

``hashlib``'s import loads OpenSSL's libcrypto (≈ 3 ms of a fresh ``latdyn run``'s process, with
``_blake2``), for ≈ 0.5 MB hashed a run (the generator's sources, the laws' and the scene's text).
CPython's own SHA-256 (``_sha256`` in 3.11, ``_sha2`` from 3.12) gives the same digest, bit for bit, at
≈ 1.4 ms for those 0.5 MB and loads nothing (docs/performance.md, "Twelfth pass: latdyn's own part of
the lattice process"). Where Python is built without it, :func:`sha256` is ``hashlib.sha256``.
"""
from __future__ import annotations

__all__ = ["sha256"]

try:
    from _sha256 import sha256
except ImportError:
    try:
        from _sha2 import sha256
    except ImportError:
        from hashlib import sha256
