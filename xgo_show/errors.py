"""One exception tree for the whole package.

Every error a user can cause is an :class:`XgoShowError`; its message is written for the user and
is printed by the CLI as one line (no traceback). Third-party errors are re-raised ``from`` the
original so the cause stays available to developers.
"""

from __future__ import annotations

__all__ = [
    "ChoreographyError",
    "CompileError",
    "NetworkError",
    "ProfileError",
    "ProtocolError",
    "RuntimeFault",
    "TransportError",
    "TransportTimeout",
    "ValueRangeError",
    "XgoShowError",
]


class XgoShowError(Exception):
    """Base of every error this package raises on purpose; the message is user-facing."""


class ProtocolError(XgoShowError):
    """Bytes that cannot be encoded or a reply that does not make sense."""


class ProfileError(XgoShowError):
    """Unknown model, register, action or capability."""


class ValueRangeError(ProfileError):
    """A physical value outside the range a register accepts."""


class TransportError(XgoShowError):
    """A port or link that cannot be opened, written or read."""


class TransportTimeout(TransportError):
    """A reply that did not arrive in time."""


class ChoreographyError(XgoShowError):
    """A routine that cannot be loaded or validated; carries every diagnostic found."""

    def __init__(self, message: str, diagnostics: tuple[object, ...] = ()) -> None:
        super().__init__(message)
        self.diagnostics = diagnostics


class CompileError(ChoreographyError):
    """A validated routine that cannot be turned into a schedule (infeasible, does not fit)."""


class NetworkError(XgoShowError):
    """A Zenoh session that cannot open, a relay that does not answer or refuses a request."""


class RuntimeFault(XgoShowError):
    """Something went wrong while a show was running; the runtime has stopped the robots."""
