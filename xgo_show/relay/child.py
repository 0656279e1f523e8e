"""The relay child of ``xgo-show run``: a process that owns the show's local ports.

Measured before it existed: ``kill -9`` of ``xgo-show run`` (or the OOM killer, or a crash)
left every dog walking with its last speeds and periodic motions, 20 of 20 times; only SIGINT
and SIGTERM stopped them. Now ``run`` starts ``xgo-show relay`` as a child that opens the local
ports and plays their part of the show, and conducts it over Zenoh on loopback like any relay.
When the conductor dies, however it dies:

- Linux sends the child SIGTERM at once (``PR_SET_PDEATHSIG``), and its end of the child's
  standard input closes;
- the child's watchdog notices the silent conductor within ``--watchdog-ms`` (elsewhere);

and the child applies the show's link-loss policy (safe stop by default, or finish the show
with ``--link-loss continue``), then exits. The child runs in its own session, so Ctrl-C and
Ctrl-Z in the terminal reach the conductor only, which stops or pauses the show as before.

What this cannot cover: the child itself killed with SIGKILL (or by the OOM killer), a cable
pulled between the host and a robot, a host that loses power. A robot has no watchdog of its
own: it keeps doing what it was last told.
"""

from __future__ import annotations

import os
import select
import socket
import subprocess
import sys
import tempfile
from collections.abc import Mapping

from xgo_show.closing import Closing
from xgo_show.errors import SetupError
from xgo_show.net.keys import relay_name_chunk

__all__ = ["READY_TIMEOUT", "RelayChild"]

#: Seconds the child may take to open its ports and its Zenoh session.
READY_TIMEOUT = 20.0


def _free_loopback_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class RelayChild(Closing):
    """Starts ``xgo-show relay`` for ``ports`` (performer -> port URL) as a child process.

    ``models`` gives each robot's model (the child then need not identify it), ``namespace``
    the Zenoh namespace; ``telemetry``, ``allow_unsafe``, ``realtime`` and ``log`` (a file
    for the child's own run log) are passed on. :attr:`endpoint` is where it listens (a free
    loopback port); :attr:`name` its relay name. Use as a context manager.
    """

    def __init__(
        self,
        ports: Mapping[str, str],
        models: Mapping[str, str],
        *,
        namespace: str,
        telemetry: bool = True,
        allow_unsafe: bool = False,
        realtime: str | None = None,
        log: str | None = None,
    ) -> None:
        host = relay_name_chunk(socket.gethostname().split(".")[0][:40])
        self.name = f"local-{host}-{os.getpid()}"
        self.endpoint = f"tcp/127.0.0.1:{_free_loopback_port()}"
        cmd = [sys.executable, "-m", "xgo_show", "relay", "--name", self.name]
        for name, url in ports.items():
            cmd += ["--map", f"{name}={url}", "--model", f"{name}={models[name]}"]
        cmd += ["--listen", self.endpoint, "--namespace", namespace]
        cmd += ["--parent-pid", str(os.getpid())]
        if not telemetry:
            cmd.append("--no-telemetry")
        if allow_unsafe:
            cmd.append("--allow-unsafe")
        if realtime is not None:  # the conductor's --realtime / --no-realtime
            cmd.append("--realtime" if realtime == "required" else "--no-realtime")
        if log:
            cmd += ["--log", log]
        self.cmd = cmd
        self.proc: subprocess.Popen[bytes] | None = None

    def start(self) -> RelayChild:
        """Start the child and wait until it is ready (its ports open, its session up)."""
        # Its errors go to a file, read if it fails to start: a pipe nobody reads during the
        # show could fill up and block it.
        with tempfile.TemporaryFile() as errors:
            self.proc = subprocess.Popen(
                self.cmd,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=errors,
                start_new_session=True,  # terminal signals go to the conductor only
            )
            assert self.proc.stdout is not None
            ready, _, _ = select.select([self.proc.stdout], [], [], READY_TIMEOUT)
            line = self.proc.stdout.readline().decode("utf-8", "replace") if ready else ""
            if "ready" in line:
                return self
            self.proc.kill()
            self.proc.wait(5)
            errors.seek(0)
            text = errors.read().decode("utf-8", "replace").strip().splitlines()
            why = text[-1].removeprefix("xgo-show: error: ") if text else "no answer in time"
            self.proc = None
            raise SetupError(f"the process that owns the local ports did not start: {why}")

    def close(self, timeout: float = 5.0) -> None:
        """Tell the child the conductor is done (its robots stay as the show left them)."""
        proc, self.proc = self.proc, None
        if proc is None:
            return
        try:
            if proc.stdin is not None:
                try:
                    proc.stdin.write(b"done\n")
                    proc.stdin.close()
                except BrokenPipeError:
                    pass  # it is gone already
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.terminate()  # SIGTERM: the child safe-stops its robots and exits
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()

    def __enter__(self) -> RelayChild:
        return self.start()
