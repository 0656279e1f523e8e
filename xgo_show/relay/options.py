"""The conductor's relay options on ``run`` and ``dry-run`` (light: imports no Zenoh).

``--map NAME=zenoh:RELAY/ROBOT`` plays a performer on a robot behind an ``xgo-show relay``;
these options say how to reach relays (Zenoh's own ``--connect``/``--listen``/
``--zenoh-config``, ``--namespace``) and what a relay does when it loses this conductor
(``--link-loss stop|continue`` after ``--watchdog-ms`` of silence).
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from xgo_show.errors import UsageError
from xgo_show.net.keys import is_relay_url
from xgo_show.net.session import SessionOptions, add_session_arguments, session_options

if TYPE_CHECKING:
    from xgo_show.compiler.schedule import Schedule
    from xgo_show.relay.child import RelayChild

__all__ = [
    "ConductorOptions",
    "add_conductor_arguments",
    "close_session",
    "conductor_options",
    "guard_local_ports",
    "use_relays",
]

#: Seconds a relay's safe stop may take, answer included (a local port's is 0.1).
RELAY_STOP_TIMEOUT = 0.5


@dataclass(frozen=True)
class ConductorOptions:
    """How this process conducts relays: its Zenoh session and the show's link-loss policy."""

    session: SessionOptions = dataclasses.field(default_factory=SessionOptions)
    link_loss: str = "stop"
    watchdog: float = 0.5  # seconds of silence before either side gives the other up
    timeout: float = 3.0  # seconds to wait for a relay's answer to a command
    name: str | None = None  # the conductor's name for people (default: user@host pid N)


def add_conductor_arguments(parser: argparse.ArgumentParser) -> None:
    """``--link-loss``, ``--watchdog-ms`` and the Zenoh session options."""
    group = parser.add_argument_group("relays (performers mapped to zenoh:RELAY/ROBOT)")
    group.add_argument(
        "--link-loss",
        choices=("stop", "continue"),
        default="stop",
        help="what a relay does when it loses this conductor: safe-stop its robots (default) "
        "or finish the uploaded show on its own",
    )
    group.add_argument(
        "--watchdog-ms",
        type=int,
        default=500,
        metavar="MS",
        help="silence after which a relay and this conductor give each other up (default 500)",
    )
    add_session_arguments(parser)


def conductor_options(args: argparse.Namespace) -> ConductorOptions:
    """The :class:`ConductorOptions` :func:`add_conductor_arguments` parsed."""
    if not 50 <= args.watchdog_ms <= 60_000:
        raise UsageError(f"--watchdog-ms {args.watchdog_ms}: give 50 to 60000")
    return ConductorOptions(
        session=session_options(args),
        link_loss=args.link_loss,
        watchdog=args.watchdog_ms / 1000,
    )


def use_relays(
    maps: Mapping[str, str],
    options: ConductorOptions | None,
    *,
    fast: bool,
    schedule: Schedule | None = None,
    simulated: Sequence[str] = (),
) -> dict[str, Any]:
    """Set up the ``zenoh:`` performers; return the launch options they need.

    The performers are those of ``maps`` and, given the ``schedule``, those whose show file
    names a relay (``port: zenoh:RELAY/ROBOT``; ``maps`` overrides it, and the ``simulated``
    performers play on simulators instead). Empty when no performer is relayed. ``--fast`` is
    refused with relays: a relay plays in real time on its own clock.
    """
    urls = {}
    if schedule is not None:
        urls = {p.name: p.port for p in schedule.performers if p.port and p.name not in simulated}
    urls.update(maps)
    relayed = sorted(n for n, url in urls.items() if is_relay_url(url))
    if not relayed:
        return {}
    if fast:
        raise UsageError(
            f"--fast cannot drive relayed performers ({', '.join(relayed)}): relays play in "
            "real time"
        )
    from xgo_show.relay.conductor import configure
    from xgo_show.relay.performer import NETWORK_LEAD

    configure(options if options is not None else ConductorOptions())
    return {"stop_timeout": RELAY_STOP_TIMEOUT, "command_lead": NETWORK_LEAD}


def close_session() -> None:
    """Close the Zenoh session the relayed performers used (if one was opened)."""
    import sys

    conductor = sys.modules.get("xgo_show.relay.conductor")
    if conductor is not None:
        conductor.close_session()


def guard_local_ports(
    schedule: Schedule,
    maps: Mapping[str, str],
    options: ConductorOptions | None,
    sim_names: Sequence[str],
    play: Any,
) -> tuple[dict[str, str], ConductorOptions | None, RelayChild | None]:
    """Hand the show's local ports to a relay child (:mod:`xgo_show.relay.child`).

    Returns the performers' new URLs (``zenoh:CHILD/NAME`` for those ports), the relay options
    that reach the child, and the child (not started yet), or the inputs unchanged when no
    performer is on a local port (simulators in this process, ``sim:`` and ``zenoh:`` URLs are
    left alone). ``play`` gives ``telemetry``, ``allow_unsafe`` and ``realtime``.
    """
    from xgo_show.relay.child import RelayChild

    urls = {p.name: p.port for p in schedule.performers if p.port}
    urls.update(maps)
    local = {
        name: url
        for name, url in urls.items()
        if url
        and name not in sim_names
        and not is_relay_url(url)
        and not url.strip().lower().startswith("sim:")
    }
    if not local:
        return dict(maps), options, None
    options = options if options is not None else ConductorOptions()
    models = {p.name: p.model for p in schedule.performers}
    child = RelayChild(
        local,
        models,
        namespace=options.session.namespace,
        telemetry=play.telemetry,
        allow_unsafe=play.allow_unsafe,
        realtime=play.realtime,
    )
    session = options.session
    asked = session.connect or session.listen or session.config_file
    if asked or any(is_relay_url(u) for u in urls.values()):
        session = dataclasses.replace(session, also_connect=(child.endpoint,))
    else:  # only the child: a private link, nothing listening on the well-known port
        session = dataclasses.replace(session, connect=(child.endpoint,))
    new_maps = dict(maps)
    new_maps.update({name: f"zenoh:{child.name}/{name}" for name in local})
    return new_maps, dataclasses.replace(options, session=session), child
