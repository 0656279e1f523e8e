"""SerialTransport over pyserial's loop:// and over real pseudo-terminals."""

from __future__ import annotations

import os
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from xgo_show.errors import TransportError
from xgo_show.transports import open_transport
from xgo_show.transports.serial_port import SerialTransport, describe_error


class PtyPair:
    """A pseudo-terminal: the test holds the master end, the port opens the slave by path."""

    def __init__(self) -> None:
        self.master, slave = os.openpty()
        self.path = os.ttyname(slave)
        os.close(slave)  # the port opens the slave by path, as it would a USB adapter
        self.closed = False

    def close_master(self) -> None:
        # Closed exactly once: a second close could hit an fd number reused by the port.
        if not self.closed:
            self.closed = True
            os.close(self.master)


@pytest.fixture
def pty_pair() -> Iterator[PtyPair]:
    pair = PtyPair()
    yield pair
    pair.close_master()


def read_exactly(fd: int, n: int, timeout: float = 2.0) -> bytes:
    out = b""
    deadline = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < deadline:
        out += os.read(fd, n - len(out))
    return out


def collect(link: SerialTransport, n: int, timeout: float = 2.0) -> bytes:
    out = b""
    deadline = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < deadline:
        out += link.read(n - len(out), timeout=0.2)
    return out


def test_loop_round_trip() -> None:
    with open_transport("loop://") as link:
        assert isinstance(link, SerialTransport)
        assert link.is_open
        link.write(b"\x55\x00\x09\x02\x07\x0a\xdb\x00\xaa")
        assert collect(link, 9) == b"\x55\x00\x09\x02\x07\x0a\xdb\x00\xaa"  # type: ignore[arg-type]
        assert link.read(16, timeout=0) == b""
    assert not link.is_open


def test_read_returns_at_most_size_and_keeps_the_rest() -> None:
    with open_transport("loop://") as link:
        link.write(bytes(range(10)))
        assert link.read(4, timeout=0.5) == bytes(range(4))
        assert link.read(100, timeout=0.5) == bytes(range(4, 10))


def test_baudrate_is_passed_to_the_port() -> None:
    link = open_transport("loop://", baudrate=9600)
    assert isinstance(link, SerialTransport)
    assert link.baudrate == 9600
    with link:
        assert link._port is not None and link._port.baudrate == 9600


def test_pty_both_directions(pty_pair: PtyPair) -> None:
    master, path = pty_pair.master, pty_pair.path
    with open_transport(path) as link:
        assert isinstance(link, SerialTransport)
        link.write(b"hello robot")
        assert read_exactly(master, 11) == b"hello robot"
        os.write(master, b"\x55\x00\x12")
        assert collect(link, 3) == b"\x55\x00\x12"  # type: ignore[arg-type]
        # A pty has no serial driver flags (TIOCGSERIAL fails): False, not an exception.
        assert link.set_low_latency() is False


def test_a_write_that_fits_never_polls_the_port(pty_pair: PtyPair, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # A tty's poll waits for the kernel worker that moves received bytes: a frame that fits
    # in the buffer must go out in one write, without pyserial's select() after it.
    import serial

    def no_pyserial_write(self: object, data: bytes) -> int:
        raise AssertionError("pyserial's write (which selects after writing) was called")

    with open_transport(pty_pair.path) as link:
        os.write(pty_pair.master, b"reply pending")  # bytes for the worker to move meanwhile
        monkeypatch.setattr(serial.Serial, "write", no_pyserial_write)
        link.write(b"a frame")
        assert read_exactly(pty_pair.master, 7) == b"a frame"


def test_a_full_port_still_times_out(pty_pair: PtyPair) -> None:
    # Nobody reads the master: the pty's buffer fills, the rest of a write waits for room
    # (pyserial's write) and gives up after the write timeout.
    from xgo_show.errors import TransportTimeout

    link = SerialTransport(pty_pair.path, write_timeout=0.2)
    link.open()
    try:
        with pytest.raises(TransportTimeout, match=r"blocked for more than 0.2 s"):
            for _ in range(1000):
                link.write(bytes(4096))
    finally:
        link.close()


def test_unopenable_path_names_port_and_reason() -> None:
    link = open_transport("/dev/ttyUSB9-does-not-exist")
    with pytest.raises(TransportError) as info:
        link.open()
    assert str(info.value) == ("cannot open /dev/ttyUSB9-does-not-exist: No such file or directory")
    assert isinstance(info.value.__cause__, OSError)
    assert not link.is_open


def test_not_a_serial_port_names_the_reason() -> None:
    with pytest.raises(TransportError, match=r"^cannot open /dev/null: .*ioctl"):
        open_transport("/dev/null").open()


def test_unknown_pyserial_url_scheme() -> None:
    with pytest.raises(TransportError, match=r"^cannot open foo://x: invalid URL"):
        open_transport("foo://x").open()


def test_port_vanishing_mid_use_raises_transport_error(pty_pair: PtyPair) -> None:
    master, path = pty_pair.master, pty_pair.path
    with open_transport(path) as link:
        link.write(b"x")
        assert read_exactly(master, 1) == b"x"
        pty_pair.close_master()  # the USB adapter is unplugged
        with pytest.raises(TransportError, match=rf"^read from {path} failed: ") as info:
            for _ in range(50):
                link.read(16, timeout=0.1)
        assert isinstance(info.value.__cause__, OSError)
        with pytest.raises(TransportError, match=rf"^write to {path} failed: "):
            for _ in range(50):
                link.write(b"more")


def test_use_before_open_is_an_error() -> None:
    link = open_transport("loop://")
    with pytest.raises(TransportError, match="loop:// is not open"):
        link.write(b"x")
    with pytest.raises(TransportError, match="loop:// is not open"):
        link.read()
    link.close()  # closing a closed port is fine


def test_low_latency_on_closed_port_is_false() -> None:
    assert open_transport("loop://").set_low_latency() is False


def test_describe_error_prefers_the_os_reason() -> None:
    cause = FileNotFoundError(2, "No such file or directory")
    err = TransportError("wrapper")
    err.__cause__ = cause
    assert describe_error(err) == "No such file or directory"
    assert describe_error(ValueError("invalid URL, protocol 'foo' not known")) == (
        "invalid URL, protocol 'foo' not known"
    )


def test_read_on_a_silent_pty_returns_nothing_after_the_timeout(pty_pair: PtyPair) -> None:
    with open_transport(pty_pair.path) as link:
        assert link.read(16, timeout=0.05) == b""
        assert link.read(16, timeout=0) == b""


def test_socket_url_round_trip_on_loopback() -> None:
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def echo_once() -> None:
        conn, _ = server.accept()
        with conn:
            conn.sendall(conn.recv(64).upper())

    thread = threading.Thread(target=echo_once, name="echo-server")
    thread.start()
    try:
        with open_transport(f"socket://127.0.0.1:{port}") as link:
            link.write(b"ping")
            assert collect(link, 4) == b"PING"  # type: ignore[arg-type]
    finally:
        thread.join(timeout=5)
        server.close()


def test_write_now_writes_and_says_when_the_buffer_is_full_or_the_fd_bad() -> None:
    import errno as _errno
    import pty

    from xgo_show.transports.serial_port import write_now

    master, slave = pty.openpty()
    try:
        os.set_blocking(slave, False)
        assert write_now(slave, b"\x55\x00\x09") == 3
        assert os.read(master, 16) == b"\x55\x00\x09"
        with pytest.raises(BlockingIOError):  # nobody reads: the buffer fills, never blocks
            for _ in range(100_000):
                write_now(slave, b"x" * 4096)
    finally:
        os.close(master)
        os.close(slave)
    with pytest.raises(OSError) as bad:
        write_now(slave, b"x")
    assert bad.value.errno == _errno.EBADF
