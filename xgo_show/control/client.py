"""A thin client of the show-control API (what ``xgo-show ctl`` and ``trigger`` use).

Every call is one Zenoh query with a JSON payload and reliable, blocking congestion control;
the answer is the server's reply as a dict, or a :class:`ControlFailed` carrying the server's
error reply (or saying that no server answered). Nothing here knows the server's internals:
examples/zenoh_control.py does the same with ``zenoh`` alone.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any

from xgo_show.control.keys import control_key, status_key, trigger_key
from xgo_show.errors import ControlFailed

if TYPE_CHECKING:
    import zenoh

__all__ = ["ControlClient", "ControlFailed"]


class ControlClient:
    """Sends commands to the ``xgo-show serve`` listening under ``namespace``."""

    def __init__(self, session: zenoh.Session, namespace: str = "xgo-show", *,
                 timeout: float = 5.0) -> None:
        self.session = session
        self.ns = namespace
        self.timeout = timeout

    def command(self, name: str, **fields: Any) -> dict[str, Any]:
        """``NS/control/NAME`` with ``fields`` (None values left out) -> the reply."""
        payload = {"v": 1, **{k: v for k, v in fields.items() if v is not None}}
        return self._get(control_key(self.ns, name), payload, name)

    def status(self) -> dict[str, Any]:
        return self._get(status_key(self.ns), None, "status")

    def trigger(self, name: str, *, source: str | None = None, data: Any = None,
                reply: bool = True) -> dict[str, Any]:
        """Fire trigger ``name``: a query (the server says whether anyone waited for it) or,
        with ``reply=False``, a put (fire and forget)."""
        payload: dict[str, Any] = {"v": 1}
        if source is not None:
            payload["source"] = source
        if data is not None:
            payload["data"] = data
        key = trigger_key(self.ns, name)
        if reply:
            return self._get(key, payload, "trigger")
        import zenoh

        self.session.put(key, json.dumps(payload).encode(),
                         congestion_control=zenoh.CongestionControl.BLOCK)
        return {"v": 1, "ok": True, "command": "trigger", "sent": True}

    def _get(self, key: str, payload: dict[str, Any] | None, what: str) -> dict[str, Any]:
        import zenoh

        data = None if payload is None else json.dumps(payload).encode()
        replies = self.session.get(
            key, payload=data, timeout=self.timeout,
            congestion_control=zenoh.CongestionControl.BLOCK,
        )
        for reply in replies:
            if reply.ok is not None:
                return _decode(reply.ok.payload.to_bytes(), what)
            err = reply.err
            assert err is not None
            body = _decode(err.payload.to_bytes(), what)
            message = str(body.get("message", body))
            if not message.startswith(what):
                message = f"{what}: {message}"
            raise ControlFailed(message, str(body.get("error", "error")), body)
        raise ControlFailed(
            f"{what}: no xgo-show serve answered on {key} within {self.timeout:g} s (is it "
            "running, with the same --namespace and reachable endpoints?)"
        )


def _decode(raw: bytes, what: str) -> dict[str, Any]:
    try:
        body = json.loads(raw)
    except ValueError as exc:
        raise ControlFailed(f"{what}: the reply is not JSON: {exc}", "bad_reply") from exc
    if not isinstance(body, dict):
        raise ControlFailed(f"{what}: the reply is not a JSON object", "bad_reply")
    return body
