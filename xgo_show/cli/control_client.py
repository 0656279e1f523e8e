"""What ``ctl`` and ``trigger`` share: the options of a control client and its session.

Both are one-shot clients of a running ``xgo-show serve``: they take the Zenoh session options
and a reply ``--timeout``, open a session, talk through a :class:`ControlClient` and close the
session whatever happened.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from xgo_show.control.client import ControlClient

__all__ = ["add_client_arguments", "control_client"]


def add_client_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--timeout`` and the Zenoh session options (``--connect``, ``--namespace``...)."""
    from xgo_show.net.session import add_session_arguments

    parser.add_argument("--timeout", type=float, default=5.0, metavar="S",
                        help="seconds to wait for the reply (default 5)")
    add_session_arguments(parser)


@contextmanager
def control_client(args: argparse.Namespace) -> Iterator[ControlClient]:
    """A :class:`ControlClient` on a session opened from ``args``, closed on the way out."""
    from xgo_show.control.client import ControlClient
    from xgo_show.net.session import open_session, session_options

    opts = session_options(args)
    session = open_session(opts)
    try:
        yield ControlClient(session, opts.namespace, timeout=args.timeout)
    finally:
        session.close()  # type: ignore[no-untyped-call]  # the stub lacks a return type
