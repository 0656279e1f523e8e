"""Interop tests: the vendors' own client libraries talk to our simulators over a real pty.

Registers the ``interop`` marker (select with ``-m interop``, skip with ``-m "not interop"``)
and provides a fixture that serves simulated robots on pseudo-terminals (``wait`` comes from
tests/conftest.py).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from xgo_show.sim import PtyServer, create_robot


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "interop: a vendor client library talks to a simulated robot over a pty"
    )


Serve = Callable[..., PtyServer]


@pytest.fixture
def serve() -> Iterator[Serve]:
    """``serve(model, **options)`` -> a started PtyServer; all are closed after the test."""
    servers: list[PtyServer] = []

    def start(model: str, **options: object) -> PtyServer:
        server = PtyServer(create_robot(model, **options)).start()
        servers.append(server)
        return server

    yield start
    for server in servers:
        server.close()
