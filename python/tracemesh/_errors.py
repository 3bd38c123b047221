"""The exceptions of the tracemesh package.

Every failure of the engine, the readers, the encoders and the service client is a :class:`Error` (a
:class:`RuntimeError`) carrying the engine's machine-readable ``code`` and its one-line message, the same message
the ``tracemesh`` command prints; a bad parameter is a :class:`ParameterError`, which is also a :class:`ValueError`.
"""

from __future__ import annotations

from typing import NoReturn, Optional

__all__ = ["Error", "ParameterError", "ServiceError", "raise_status"]


class Error(RuntimeError):
    """A tracemesh failure: ``code`` names it ("invalid_input", "nothing_to_mesh", "io_error", ...)."""

    def __init__(self, message: str, code: str = "internal_error") -> None:
        super().__init__(message)
        self.message = message
        self.code = code


class ParameterError(Error, ValueError):
    """A parameter or argument out of its range or malformed (code "invalid_argument")."""


class ServiceError(Error):
    """A tracemeshd answer that is an error: ``status`` is the HTTP status (0 when the job failed after it was
    accepted), ``code`` and ``message`` the body's ``{"error": {"code", "message"}}``."""

    def __init__(self, message: str, code: str, status: int = 0, job_id: Optional[str] = None) -> None:
        super().__init__(message, code)
        self.status = status
        self.job_id = job_id


# Shown as tracemesh.Error (the package exports them), not as the private module's.
for _exception in (Error, ParameterError, ServiceError):
    _exception.__module__ = "tracemesh"


def raise_status(code: str, message: str) -> NoReturn:
    """Raises the exception of an engine error code (called by the extension module)."""
    if code == "invalid_argument":
        raise ParameterError(message, code)
    raise Error(message, code)
