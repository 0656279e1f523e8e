"""Clock sync over Zenoh: a relay serves its clock, the conductor measures and tracks it.

On the relay, :func:`serve_time` declares a queryable (``NS/relay/NAME/time``, see
:mod:`xgo_show.net.keys`) that stamps each ping with the relay's own clock and takes timebase
updates for its show clock. On the conductor, :func:`measure` runs a burst of pings and returns
an :class:`~xgo_show.net.offset.OffsetEstimate`; a :class:`ClockTracker` keeps measuring
during a show, fits the drift (:class:`~xgo_show.net.offset.DriftFit`) and pushes each new
:class:`~xgo_show.net.offset.Timebase` to the relay, whose
:class:`~xgo_show.net.slew.SlewingClock` slews onto it. Once the first timebase is taken, the
relay's show clock reads the conductor's time, so a time a command carries means the same
instant on both hosts, and stays so for the whole show.

Wiring::

    # relay                                        # conductor
    base = clock_from_env()                        tracker = ClockTracker(session, time_key,
    show_clock = SlewingClock(base)                                       conductor=my_id)
    server = serve_time(session, time_key, base,   tracker.start()   # first burst + push
        on_timebase=lambda tb, who:                ...               # times in my own clock
            show_clock.follow(tb))                 tracker.close()
    # executors run on show_clock

Payloads are versioned JSON (one object, at most :data:`MAX_PAYLOAD` bytes): readable in a
packet dump and in logs, and decoding costs microseconds, which is outside the measured interval
on the conductor (stamped before encoding and after the reply arrives) and inside ``t2 - t1``
(subtracted) on the relay::

    ping       {"v": 1, "op": "ping", "seq": 7}
      reply    {"v": 1, "seq": 7, "t1": 12.345678901, "t2": 12.345712345}
    timebase   {"v": 1, "op": "timebase", "conductor": "5f1c...", "offset": 2.5,
                "rate": 8.1e-05, "ref": 1234.5, "bound": 6e-05, "rate_bound": 2e-06}
      reply    {"v": 1, "ok": true, "correction": -1.2e-05}

An unreadable request or a refused timebase gets an error reply ``{"v": 1, "error": "..."}``.
Floats are written with Python's shortest round-trip repr, so no precision is lost.
"""

from __future__ import annotations

import contextlib
import json
import math
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from xgo_show.errors import TimeSyncError, XgoShowError
from xgo_show.net.offset import DriftFit, Exchange, OffsetEstimate, Timebase, estimate_offset
from xgo_show.net.testhooks import DelayInjector
from xgo_show.runtime.clock import Clock, MonotonicClock

if TYPE_CHECKING:
    import zenoh

__all__ = [
    "MAX_PAYLOAD",
    "SYNC_VERSION",
    "ClockTracker",
    "TimeServer",
    "TimeSyncError",
    "TrackerUpdate",
    "measure",
    "serve_time",
]

SYNC_VERSION = 1
MAX_PAYLOAD = 1024


# ---------------------------------------------------------------------------- payloads


def _encode(obj: dict[str, Any]) -> bytes:
    return json.dumps(obj, separators=(",", ":")).encode()


def _decode(data: bytes) -> dict[str, Any]:
    if len(data) > MAX_PAYLOAD:
        raise ValueError(f"time-sync payload of {len(data)} bytes (at most {MAX_PAYLOAD})")
    try:
        obj = json.loads(data)
    except ValueError:
        raise ValueError("time-sync payload is not JSON") from None
    if not isinstance(obj, dict):
        raise ValueError("time-sync payload is not a JSON object")
    if obj.get("v") != SYNC_VERSION:
        raise ValueError(f"time-sync version {obj.get('v')!r}, this side speaks {SYNC_VERSION}")
    return obj


def _number(obj: dict[str, Any], name: str) -> float:
    value = obj.get(name)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"time-sync field {name!r} must be a finite number")
    return float(value)


def _timebase(obj: dict[str, Any]) -> Timebase:
    tb = Timebase(*(_number(obj, n) for n in ("offset", "rate", "ref", "bound", "rate_bound")))
    if abs(tb.rate) >= 0.01 or tb.bound < 0 or tb.rate_bound < 0:
        raise ValueError("time-sync timebase out of range (|rate| < 1%, bounds >= 0)")
    return tb


def _payload(sample: zenoh.Sample | zenoh.Query) -> bytes:
    payload = sample.payload
    return b"" if payload is None else payload.to_bytes()


def _undeclare(entity: zenoh.Queryable[None] | zenoh.Querier) -> None:
    """Undeclare, quietly if the session is already closed."""
    with contextlib.suppress(Exception):
        entity.undeclare()  # type: ignore[no-untyped-call]  # the stub lacks a return type


# ---------------------------------------------------------------------------- relay side


class TimeServer:
    """The relay's time queryable (see :func:`serve_time`); :meth:`close` withdraws it."""

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        clock: Clock,
        on_timebase: Callable[[Timebase, str], object] | None,
        delay: DelayInjector | None,
        hold_off: Callable[[], object] | None = None,
    ) -> None:
        self.key = key
        self.hold_off = hold_off
        self.clock = clock
        self.on_timebase = on_timebase
        self.delay = delay
        self._delayed: queue.Queue[tuple[zenoh.Query, bytes, float] | None] = queue.Queue()
        self._thread: threading.Thread | None = None
        if delay is not None:
            self._thread = threading.Thread(
                target=self._late, name="xgo-show time-sync delay", daemon=True
            )
            self._thread.start()
        self._queryable = session.declare_queryable(key, self._on_query)

    def _on_query(self, query: zenoh.Query) -> None:
        t1 = self.clock.now()
        if self.hold_off is not None:
            # Not while a writer of this process needs Python's lock; between the two stamps,
            # so the estimate leaves the wait out (Exchange.rtt).
            self.hold_off()
        try:
            request = _decode(_payload(query))
            op = request.get("op")
            if op == "ping":
                seq = request.get("seq")
                reply = {"v": SYNC_VERSION, "seq": seq, "t1": t1, "t2": self.clock.now()}
                if self.delay is not None:
                    self._delayed.put((query, _encode(reply), time.monotonic()))
                    return
                query.reply(self.key, _encode(reply), express=True)
            elif op == "timebase":
                correction = self._take(request)
                query.reply(self.key, _encode({"v": SYNC_VERSION, "ok": True, **correction}))
            else:
                raise ValueError(f"time-sync op {op!r} (expected ping or timebase)")
        except (ValueError, XgoShowError) as exc:
            query.reply_err(_encode({"v": SYNC_VERSION, "error": str(exc)}))

    def _take(self, request: dict[str, Any]) -> dict[str, Any]:
        timebase = _timebase(request)
        conductor = request.get("conductor")
        if not isinstance(conductor, str):
            raise ValueError("time-sync timebase without a conductor id")
        if self.on_timebase is None:
            raise ValueError("this clock takes no timebase")
        out = self.on_timebase(timebase, conductor)
        return {"correction": out} if isinstance(out, float) else {}

    def _late(self) -> None:
        assert self.delay is not None
        while True:
            item = self._delayed.get()
            if item is None:
                return
            query, data, stamped = item
            wait = stamped + self.delay.draw() - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            query.reply(self.key, data, express=True)
            query.drop()  # type: ignore[no-untyped-call]  # the stub lacks a return type

    def close(self) -> None:
        """Undeclare the queryable and stop the delay thread, if any."""
        _undeclare(self._queryable)
        if self._thread is not None:
            self._delayed.put(None)
            self._thread.join(2.0)


def serve_time(
    session: zenoh.Session,
    key: str,
    clock: Clock,
    *,
    on_timebase: Callable[[Timebase, str], object] | None = None,
    delay: DelayInjector | None = None,
    hold_off: Callable[[], object] | None = None,
) -> TimeServer:
    """Answer time-sync pings on ``key`` with readings of ``clock`` (the relay's base clock).

    ``on_timebase(timebase, conductor_id)`` takes a conductor's timebase (typically
    :meth:`SlewingClock.follow <xgo_show.net.slew.SlewingClock.follow>` after checking that
    this conductor holds the relay); it raises an :class:`~xgo_show.errors.XgoShowError` to
    refuse, and may return the correction (a float) for the reply. ``delay`` (test-only) holds
    every ping reply back after stamping it, as a slow network would. ``hold_off()`` is called
    first in each answer (a relay's :meth:`SlewingClock.hold_off
    <xgo_show.net.slew.SlewingClock.hold_off>`: the answer waits while a writer is due),
    between the reply's two stamps, so the estimate leaves the wait out.
    """
    return TimeServer(session, key, clock, on_timebase, delay, hold_off)


# ---------------------------------------------------------------------------- conductor side


def _ping(querier: zenoh.Querier, clock: Clock, seq: int) -> Exchange | None:
    """One exchange, or None if no good reply came before the querier's timeout."""
    payload = _encode({"v": SYNC_VERSION, "op": "ping", "seq": seq})
    t0 = clock.now()
    replies = querier.get(payload=payload)
    for reply in replies:
        t3 = clock.now()
        ok = reply.ok
        if ok is None:
            return None
        try:
            answer = _decode(ok.payload.to_bytes())
            if answer.get("seq") != seq:
                return None
            return Exchange(t0, _number(answer, "t1"), _number(answer, "t2"), t3)
        except ValueError:
            return None
    return None


def _querier(session: zenoh.Session, key: str, timeout: float) -> zenoh.Querier:
    import zenoh

    return session.declare_querier(
        key,
        timeout=timeout,
        target=zenoh.QueryTarget.ALL,
        consolidation=zenoh.ConsolidationMode.NONE,
        express=True,
    )


def _burst(querier: zenoh.Querier, clock: Clock, n: int, first_seq: int) -> list[Exchange]:
    out = []
    for i in range(n):
        x = _ping(querier, clock, first_seq + i)
        if x is not None:
            out.append(x)
    return out


def measure(
    session: zenoh.Session,
    key: str,
    *,
    n: int = 25,
    clock: Clock | None = None,
    timeout: float = 0.5,
) -> OffsetEstimate:
    """``n`` pings to the time server on ``key``; the offset they agree on (relay - ours).

    Raises :class:`TimeSyncError` when no ping is answered.
    """
    clock = MonotonicClock() if clock is None else clock
    querier = _querier(session, key, timeout)
    try:
        exchanges = _burst(querier, clock, n, 1)
    finally:
        _undeclare(querier)
    if not exchanges:
        raise TimeSyncError(f"{key}: no answer to {n} time-sync pings within {timeout:g} s each")
    return estimate_offset(exchanges)


@dataclass(frozen=True)
class TrackerUpdate:
    """What one tracking round found (for logs): the burst's estimate and the timebase."""

    estimate: OffsetEstimate
    timebase: Timebase
    pushed: bool
    error: str = ""


class ClockTracker:
    """Keeps one relay's clock measured, fits its drift and pushes the timebase to it.

    :meth:`start` runs a first burst of ``first`` pings and pushes the result (so the relay's
    show clock reads the conductor's time when it returns), then a thread runs a burst of
    ``burst`` pings every ``interval`` seconds and pushes each new timebase. ``on_update`` is
    called from that thread after every round. ``push=False`` only measures.
    """

    def __init__(
        self,
        session: zenoh.Session,
        key: str,
        *,
        conductor: str,
        clock: Clock | None = None,
        interval: float = 1.0,
        burst: int = 8,
        first: int = 25,
        timeout: float = 0.5,
        push: bool = True,
        on_update: Callable[[TrackerUpdate], None] | None = None,
    ) -> None:
        self.session = session
        self.key = key
        self.conductor = conductor
        self.clock: Clock = MonotonicClock() if clock is None else clock
        self.interval = interval
        self.burst = burst
        self.first = first
        self.timeout = timeout
        self.push = push
        self.on_update = on_update
        self.fit = DriftFit()
        self._lock = threading.Lock()
        self._timebase: Timebase | None = None
        self._seq = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._querier: zenoh.Querier | None = None
        #: Why tracking stopped on its own (the session closed under it), if it did.
        self.failure = ""

    @property
    def timebase(self) -> Timebase | None:
        """The newest timebase (None before :meth:`start`)."""
        with self._lock:
            return self._timebase

    def start(self) -> Timebase:
        """First burst and push (raises :class:`TimeSyncError`), then keep tracking."""
        self._querier = _querier(self.session, self.key, self.timeout)
        update = self.round(self.first)
        if update is None:
            self.close()
            raise TimeSyncError(
                f"{self.key}: no answer to {self.first} time-sync pings within "
                f"{self.timeout:g} s each"
            )
        if update.error:
            self.close()
            raise TimeSyncError(f"{self.key}: {update.error}")
        self._thread = threading.Thread(
            target=self._run, name="xgo-show clock tracker", daemon=True
        )
        self._thread.start()
        return update.timebase

    def round(self, n: int) -> TrackerUpdate | None:
        """One burst of ``n`` pings, fit and push; None if no ping was answered."""
        querier = self._querier
        if querier is None:
            raise RuntimeError("ClockTracker.round before start")
        exchanges = _burst(querier, self.clock, n, self._seq + 1)
        self._seq += n
        if not exchanges:
            return None
        estimate = estimate_offset(exchanges)
        timebase = self.fit.add(estimate)
        with self._lock:
            self._timebase = timebase
        error = self._push(timebase) if self.push else ""
        update = TrackerUpdate(estimate, timebase, self.push and not error, error)
        if self.on_update is not None:
            self.on_update(update)
        return update

    def _push(self, timebase: Timebase) -> str:
        import zenoh

        payload = _encode(
            {"v": SYNC_VERSION, "op": "timebase", "conductor": self.conductor, **asdict(timebase)}
        )
        for reply in self.session.get(
            self.key,
            payload=payload,
            timeout=self.timeout,
            congestion_control=zenoh.CongestionControl.BLOCK,
        ):
            if reply.ok is not None:
                return ""
            err = reply.err
            text = "" if err is None else err.payload.to_bytes().decode("utf-8", "replace")
            try:
                return str(_decode(text.encode()).get("error", text))
            except ValueError:
                return text or "timebase refused"
        return f"no answer to the timebase within {self.timeout:g} s"

    def _run(self) -> None:
        next_at = self.clock.now() + self.interval
        while self.clock.sleep_until(next_at, self._stop):
            try:
                self.round(self.burst)
            except Exception as exc:  # the session closed under us: stop tracking, say why
                self.failure = f"clock tracking of {self.key} stopped: {exc}"
                return
            next_at += self.interval

    def close(self) -> None:
        """Stop tracking (the relay's show clock keeps its last timebase)."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        if self._querier is not None:
            _undeclare(self._querier)
            self._querier = None
