"""One exception tree for the whole package.

Every error a user can cause is an :class:`XgoShowError`; its message is written for the user and
is printed by the CLI as one line (no traceback). Third-party errors are re-raised ``from`` the
original so the cause stays available to developers. Each kind of failure has its own class,
so that a caller (a relay, a show-control server, a test) can tell them apart::

    XgoShowError
    ├── UsageError               a command-line option or argument that makes no sense
    ├── FileAccessError          a file that cannot be read or written (missing, not a regular
    │                            file, too large, not UTF-8, no permission)
    ├── ScheduleError            a compiled schedule (.xshow.json) that is malformed or impossible
    │   └── UnsafeScheduleError  a schedule writing a register no show may touch
    ├── ProtocolError            bytes that cannot be encoded, a reply that makes no sense
    │   └── FrameRejected        a well-formed frame a (simulated) robot refuses
    ├── ProfileError             unknown model, register, action or capability
    │   └── ValueRangeError      a physical value outside a register's range
    ├── TransportError           a port or link that cannot be opened, written or read
    │   └── TransportTimeout     a reply that did not arrive in time
    ├── ChoreographyError        a routine that does not load or validate (with diagnostics)
    │   └── CompileError         a valid routine that cannot become a schedule
    │       └── TrajectoryError  the trajectory planner refused a move's input
    │           └── InfeasibleMotion  a move shorter than its limits allow
    ├── NetworkError             a Zenoh session that cannot open, a relay that does not answer
    │   ├── MessageError         a payload that is not a valid message of the relay protocol
    │   ├── RelayRefused         a relay that refuses a command (held by another conductor, ...)
    │   │   └── UploadRefused    an uploaded schedule the relay will not run
    │   └── ControlFailed        a show-control server refused a command, or none answered
    ├── ControlError             a show-control command or trigger that cannot be carried out now
    ├── SetupError               a show that cannot be set up (a performer without a port, ...)
    ├── PreflightError           a pre-flight check failed; nothing was moved
    ├── SimulatorError           a simulator that cannot serve or stopped
    ├── AudioError               a soundtrack that cannot be decoded or played
    │   └── NoAudioDevice        no sound card or sound server to play on
    ├── TimeSyncError            a relay that does not answer time-sync pings
    ├── TimecodeError            a timecode/OSC input that cannot be opened or never starts
    ├── PlotError                a plot that cannot be drawn (no matplotlib, cannot write)
    └── RuntimeFault             something went wrong while a show ran; the robots were stopped
"""

from __future__ import annotations

from xgo_show.diagnostics import Diagnostic

__all__ = [
    "AudioError",
    "ChoreographyError",
    "CompileError",
    "ControlError",
    "ControlFailed",
    "FileAccessError",
    "FrameRejected",
    "InfeasibleMotion",
    "MessageError",
    "NetworkError",
    "NoAudioDevice",
    "PlotError",
    "PreflightError",
    "ProfileError",
    "ProtocolError",
    "RelayRefused",
    "RuntimeFault",
    "ScheduleError",
    "SetupError",
    "SimulatorError",
    "TimeSyncError",
    "TimecodeError",
    "TrajectoryError",
    "TransportError",
    "TransportTimeout",
    "UnsafeScheduleError",
    "UploadRefused",
    "UsageError",
    "ValueRangeError",
    "XgoShowError",
]


class XgoShowError(Exception):
    """Base of every error this package raises on purpose; the message is user-facing."""


class UsageError(XgoShowError):
    """A command-line option or argument that makes no sense (a negative countdown, ...)."""


class FileAccessError(XgoShowError):
    """A file that cannot be read or written: missing, a directory, a pipe or device, too
    large, not UTF-8 text, or not permitted. ``line``/``column`` say where in the file the
    problem is when it is in the content (a byte that is not UTF-8); 1:1 otherwise."""

    def __init__(self, message: str, *, line: int = 1, column: int = 1) -> None:
        super().__init__(message)
        self.line = line
        self.column = column


class ScheduleError(XgoShowError):
    """A compiled schedule file that is malformed or describes something impossible."""


class UnsafeScheduleError(ScheduleError):
    """A schedule writes a register that is never touched during a show."""


class ProtocolError(XgoShowError):
    """Bytes that cannot be encoded or a reply that does not make sense."""


class FrameRejected(ProtocolError):
    """A well-formed frame a (simulated) robot refuses; the message is the recorded reason."""


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

    def __init__(self, message: str, diagnostics: tuple[Diagnostic, ...] = ()) -> None:
        super().__init__(message)
        self.diagnostics: tuple[Diagnostic, ...] = diagnostics


class CompileError(ChoreographyError):
    """A validated routine that cannot be turned into a schedule (infeasible, does not fit)."""


class NetworkError(XgoShowError):
    """A Zenoh session that cannot open, a relay that does not answer or refuses a request."""


class MessageError(NetworkError):
    """A payload that is not a valid message of the relay protocol."""


class RelayRefused(NetworkError):
    """A relay that refuses a command: held by another conductor, no show to start or pause,
    an operation it does not support."""


class UploadRefused(RelayRefused):
    """An uploaded schedule the relay will not run; the message says why."""


class ControlFailed(NetworkError):
    """A show-control server (``xgo-show serve``) refused a command, or none answered.

    ``code`` is the server's error code (``no_reply`` when nobody answered; see
    docs/zenoh-api.md) and ``reply`` its whole error reply.
    """

    def __init__(
        self, message: str, code: str = "no_reply", reply: dict[str, object] | None = None
    ) -> None:
        super().__init__(message)
        self.code = code
        self.reply = dict(reply or {})


class ControlError(XgoShowError):
    """A show-control request that is malformed or cannot be carried out now (no show running,
    nobody waits for that trigger, ...): the message says why, ``code`` names the kind for
    programs (``refused``, ``bad_request``, ...: the error replies of docs/zenoh-api.md)."""

    def __init__(self, message: str, code: str = "refused") -> None:
        super().__init__(message)
        self.code = code


class TrajectoryError(CompileError):
    """The trajectory planner rejected a move's input (limits it cannot work with)."""


class InfeasibleMotion(TrajectoryError):
    """The requested duration is shorter than the limits allow."""

    def __init__(self, minimum: float, dof: int, requested: float) -> None:
        super().__init__(f"needs at least {minimum:.2f} s, given {requested:.2f} s")
        self.minimum = minimum
        self.dof = dof  # index of the DoF that needs the longest time alone
        self.requested = requested


class SetupError(XgoShowError):
    """A show that cannot be set up as asked: a performer without a port, two performers on
    one port, an unknown failure policy."""


class PreflightError(XgoShowError):
    """A pre-flight check failed; nothing was moved."""


class SimulatorError(XgoShowError):
    """A simulator that cannot serve (bad option) or that stopped."""


class AudioError(XgoShowError):
    """A soundtrack that cannot be decoded or played (audio modules missing, a file that is
    not sound, an output that does not exist)."""


class NoAudioDevice(AudioError):
    """No sound card or sound server to play on."""


class TimeSyncError(XgoShowError):
    """A relay that does not answer time-sync pings, or refuses a timebase."""


class TimecodeError(XgoShowError):
    """A timecode or OSC input that cannot be opened, or that never started the show."""


class PlotError(XgoShowError):
    """A plot that cannot be drawn: matplotlib missing or the image not writable."""


class RuntimeFault(XgoShowError):
    """Something went wrong while a show was running; the runtime has stopped the robots."""
