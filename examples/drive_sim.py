"""Drive a simulated XGO robot over a real pseudo-terminal and show what it received.

The simulator serves the robot on a pty exactly as a USB serial adapter would appear; this
script opens that path with the same transport and client a real robot gets, identifies the
robot from its firmware, walks it forward, turns, stops, changes posture, runs a preset action,
and then prints every frame the robot received, decoded by its profile.

    python examples/drive_sim.py [--model mini|lite|rider] [--hex]
"""

from __future__ import annotations

import argparse
import sys
import time

from xgo_show.client import XgoClient
from xgo_show.profiles import Profile, get_profile, model_from_firmware
from xgo_show.sim import PtyServer, ReceivedFrame, create_robot
from xgo_show.transports import open_transport
from xgo_show.wire.xgo import XgoDecoder


def main(model: str = "mini", *, hex_log: bool = False, pace: float = 1.0) -> int:
    profile = get_profile(model)
    robot = create_robot(profile.model)
    with PtyServer(robot) as server:
        print(f"simulated {profile.title} on {server.path}")
        # hex+<url> wraps the port in a logger of every byte sent and received.
        url, options = (
            (f"hex+{server.path}", {"stream": sys.stdout}) if hex_log else (server.path, {})
        )
        with open_transport(url, baudrate=profile.link.baud, **options) as link:
            client = XgoClient(link, profile)
            drive(client, pace=pace)
            server.settle()  # the robot has read every byte written (on a busy machine too)
        with server.lock:
            received = list(robot.received)
    print(f"\nthe robot received {len(received)} frames:")
    start = received[0].t if received else 0.0
    for frame in received:
        print(describe(profile, frame, start))
    return 0


def drive(client: XgoClient, *, pace: float = 1.0) -> None:
    """A short routine: identify, walk, turn, stop, lean, run a preset action, reset.

    ``pace`` scales every hold time (0.1 runs ten times faster, for tests).
    """
    profile = client.profile
    firmware = client.firmware()
    print(f"firmware {firmware!r} (model {model_from_firmware(firmware)}), ", end="")
    print(f"battery {client.battery()} %")
    vx, vyaw = profile.register("vx"), profile.register("vyaw")
    assert vx.maximum is not None and vyaw.maximum is not None
    steps: list[tuple[str, object, float]] = [
        ("vx", vx.maximum / 2, 0.4),  # walk forward at half speed
        ("vyaw", vyaw.maximum / 4, 0.3),  # and turn left while walking
        ("vx", 0.0, 0.0),  # stop: zero is exactly the neutral byte 0x80
        ("vyaw", 0.0, 0.2),
        ("roll", _middle_high(profile, "roll"), 0.2),  # lean
        ("body_z", _middle_high(profile, "body_z"), 0.2),  # stand taller
        ("roll", 0.0, 0.1),
    ]
    for name, value, hold in steps:
        client.write(name, value)
        time.sleep(hold * pace)
    action = client.action(profile.actions[0].name)
    print(f"running action {action.id} {action.name}")
    time.sleep(0.3 * pace)
    client.action("reset")  # 255 restores the default posture
    time.sleep(0.05 * pace)


def describe(profile: Profile, received: ReceivedFrame, start: float) -> str:
    """One line per received frame: time, kind, register values and the raw bytes."""
    stamp = f"+{received.t - start:6.3f} s"
    frames = XgoDecoder().feed(received.data)
    if not frames:
        return f"{stamp}  ?      {received.data.hex(' ')}"
    frame = frames[0]
    if frame.is_read:
        reg = profile.register_at(frame.address)
        name = reg.name if reg is not None else f"0x{frame.address:02X}"
        count = frame.data[0]
        text = f"read   {name} ({count} byte{'s' if count != 1 else ''})"
    else:
        parts = []
        offset = 0
        for reg in profile.walk(frame.address, len(frame.data)):
            value = reg.decode_value(frame.data[offset : offset + reg.size])
            if reg.name == "action" and isinstance(value, int):
                value = f"{value} {profile.action(value).name}"
            elif isinstance(value, float):
                value = f"{value:g}{' ' + reg.unit if reg.unit else ''}"
            parts.append(f"{reg.name} = {value}")
            offset += reg.size
        text = "write  " + ", ".join(parts)
    if not received.accepted:
        text += f"  REFUSED: {received.reason}"
    return f"{stamp}  {text:<42} [{received.data.hex(' ')}]"


def _middle_high(profile: Profile, name: str) -> float:
    """A value three quarters up a register's range (always valid for that model)."""
    reg = profile.register(name)
    assert reg.minimum is not None and reg.maximum is not None
    return round(reg.minimum + 0.75 * (reg.maximum - reg.minimum), 1)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="mini", choices=("mini", "lite", "rider"))
    parser.add_argument("--hex", action="store_true", help="log the serial traffic in hex")
    parser.add_argument("--pace", type=float, default=1.0, help="scale hold times (default 1)")
    args = parser.parse_args()
    sys.exit(main(args.model, hex_log=args.hex, pace=args.pace))
