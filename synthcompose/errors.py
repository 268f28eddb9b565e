"""Typed errors. Every error about input names the file and the problem."""
from __future__ import annotations

from pathlib import Path


class SynthComposeError(Exception):
    """Base of every error this package raises on purpose."""


class InputError(SynthComposeError):
    """A file the user gave us is missing, unreadable or not what we expect.

    ``str(err)`` reads ``"<path>: <problem>"`` so a batch summary can print it as is.
    """

    def __init__(self, path: str | Path, problem: str) -> None:
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")

    def __reduce__(self):  # keep picklable across worker processes
        return (type(self), (self.path, self.problem))


class ManifestError(InputError):
    """The batch manifest is invalid (the message names the field)."""


class ModelError(InputError):
    """A 3D model file cannot be used."""


class OutputError(SynthComposeError):
    """An output file cannot be written (disk full, no permission); names the file."""

    def __init__(self, path: str | Path, problem: str) -> None:
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")

    def __reduce__(self):
        return (type(self), (self.path, self.problem))


class GLContextError(SynthComposeError):
    """No OpenGL context could be created; the message says what to install."""


class ShaderError(SynthComposeError):
    """A GLSL file failed to compile or link; the message names the file."""
