"""Network-namespace "hosts" for tests: real separate TCP stacks on one machine.

:func:`two_hosts` (a fixture, registered in ``tests/net/conftest.py``) makes two namespaces
joined by a veth pair, 10.77.0.1 and 10.77.0.2, and removes them afterwards with everything
still running inside. ``Cable.unplug`` takes one end down: a pulled network cable, which TCP
does not notice (``tc netem`` is not available in this kernel, so delays are injected by a
test-only hook instead, :mod:`xgo_show.net.testhooks`).
"""

from __future__ import annotations

import contextlib
import itertools
import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import pytest


@dataclass
class Host:
    """A network namespace this test made: its own TCP stack, one veth with ``address``."""

    netns: str
    device: str
    address: str

    def command(self, *args: str) -> list[str]:
        """``args`` run inside this host."""
        return ["ip", "netns", "exec", self.netns, *args]

    def popen(self, args: Sequence[str], **kwargs: Any) -> subprocess.Popen[str]:
        """Start a process inside this host (text mode, output piped unless told otherwise)."""
        kwargs.setdefault("stdout", subprocess.PIPE)
        kwargs.setdefault("stderr", subprocess.PIPE)
        return subprocess.Popen(self.command(*args), text=True, **kwargs)


@dataclass
class Cable:
    """The veth pair between two hosts; :meth:`unplug` is a pulled network cable."""

    a: Host
    b: Host

    def unplug(self) -> None:
        """Take host a's end down: packets stop both ways and TCP notices nothing."""
        _ip("-n", self.a.netns, "link", "set", self.a.device, "down")

    def plug(self) -> None:
        _ip("-n", self.a.netns, "link", "set", self.a.device, "up")


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True, timeout=10)


_made = itertools.count()


@pytest.fixture
def two_hosts() -> Iterator[tuple[Host, Host, Cable]]:
    """Two "hosts" (network namespaces joined by a veth pair, 10.77.0.1 and .2), removed after.

    Skips, saying why, where namespaces cannot be made (not root, no ``ip``, a container
    without CAP_SYS_ADMIN). No traffic leaves them: the root namespace has no end of the pair.
    """
    if not sys.platform.startswith("linux") or shutil.which("ip") is None:
        pytest.skip("network namespaces need Linux and the ip command (iproute2)")
    if os.geteuid() != 0:
        pytest.skip("creating network namespaces needs root (CAP_SYS_ADMIN)")
    tag = f"{os.getpid() % 100000}x{next(_made)}"
    a = Host(f"xgo-{tag}-a", f"xa{tag}", "10.77.0.1")
    b = Host(f"xgo-{tag}-b", f"xb{tag}", "10.77.0.2")
    made: list[str] = []
    try:
        for host in (a, b):
            _ip("netns", "add", host.netns)
            made.append(host.netns)
        _ip("link", "add", a.device, "netns", a.netns, "type", "veth",
            "peer", "name", b.device, "netns", b.netns)  # fmt: skip
        for host in (a, b):
            _ip("-n", host.netns, "addr", "add", f"{host.address}/24", "dev", host.device)
            _ip("-n", host.netns, "link", "set", host.device, "up")
            _ip("-n", host.netns, "link", "set", "lo", "up")
    except (subprocess.CalledProcessError, OSError) as exc:
        _remove(made)
        detail = exc.stderr.strip() if isinstance(exc, subprocess.CalledProcessError) else exc
        pytest.skip(f"cannot create network namespaces here: {detail}")
    try:
        yield a, b, Cable(a, b)
    finally:
        _remove(made)


def _remove(names: list[str]) -> None:
    """Kill what still runs inside, then delete the namespaces (their veth goes with them)."""
    for name in names:
        pids = subprocess.run(
            ["ip", "netns", "pids", name], capture_output=True, text=True, timeout=10
        ).stdout.split()
        for pid in pids:
            with contextlib.suppress(ProcessLookupError, ValueError):
                os.kill(int(pid), signal.SIGKILL)
        subprocess.run(["ip", "netns", "del", name], capture_output=True, timeout=10)
