"""Exceptions that the command line turns into exit statuses (SCENE.md)."""
from __future__ import annotations


class SceneError(ValueError):
    """An invalid scene: exit status 2, message on stderr, nothing solved.

    The message always names the file, the key path (``beams.arm.section``)
    and what was expected there.
    """

    def __init__(self, file: str | None, key: str, expected: str):
        self.file = file or "<scene>"
        self.key = key
        self.expected = expected
        super().__init__(f"{self.file}: {key}: {expected}")


class SolverError(RuntimeError):
    """The solver failed: exit status 1; what was recorded stays readable."""

    def __init__(self, message: str, diagnosis: str = ""):
        self.diagnosis = diagnosis
        super().__init__(message if not diagnosis else f"{message}\n{diagnosis}")
