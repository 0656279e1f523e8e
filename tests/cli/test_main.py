"""The xgo-show entry point: command list, probe output and one-line errors."""

from __future__ import annotations

import argparse
import gc
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from xgo_show.cli.main import COMMANDS, build_parser, main, program
from xgo_show.sim import PtyServer, create_robot


def command_names() -> list[str]:
    """The subcommand names the parser registers (one per module in COMMANDS)."""
    parser = build_parser()
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return list(subparsers.choices)


def test_help_lists_every_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    names = command_names()
    assert "probe" in COMMANDS and "probe" in names
    assert len(names) == len(COMMANDS)
    for name in names:
        assert f"    {name} " in out, name


def test_every_command_has_help(capsys: pytest.CaptureFixture[str]) -> None:
    for name in command_names():
        with pytest.raises(SystemExit) as info:
            main([name, "--help"])
        assert info.value.code == 0
        assert "usage: xgo-show " + name in capsys.readouterr().out


def test_every_command_help_ends_with_examples_kept_on_their_own_lines(
    capsys: pytest.CaptureFixture[str],
) -> None:
    for name in command_names():
        with pytest.raises(SystemExit):
            main([name, "--help"])
        out = capsys.readouterr().out
        _, sep, examples = out.rpartition("\nexample:\n")
        assert sep, f"{name} --help has no example"
        lines = examples.rstrip("\n").split("\n")
        # The first example runs the command itself; no example was rewrapped into prose.
        assert lines[0].startswith(f"  xgo-show {name} "), (name, lines)
        assert all(line.startswith("  xgo-show ") for line in lines), (name, lines)


def test_probe_sim_prints_firmware_model_battery(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["probe", "sim:mini"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "port      sim:mini",
        "model     mini (from firmware)",
        "firmware  M-1.4.1",
        "battery   100 %",
        "status    0x00",
    ]


def test_probe_rider_shows_named_status(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["probe", "sim:rider", "--timeout", "1"]) == 0
    assert "status    normal (0x01)" in capsys.readouterr().out


def test_probe_xarm_shows_voltage_and_servos(capsys: pytest.CaptureFixture[str]) -> None:
    robot = create_robot("xarm", battery_mv=7450, drain_mv_per_minute=0, positions={1: 0})
    with PtyServer(robot) as server:
        assert main(["probe", server.path, "--model", "xarm"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1:4] == ["model    xarm", "battery  7.45 V", "servo 1     0  (-125.0 deg)"]
    assert out[4:] == [f"servo {n}   500  (+0.0 deg)" for n in range(2, 7)]


def test_probe_over_a_simulated_pty(capsys: pytest.CaptureFixture[str]) -> None:
    robot = create_robot("lite", battery=42)
    with PtyServer(robot) as server:
        assert main(["probe", server.path]) == 0
    out = capsys.readouterr().out
    assert f"port      {server.path}\n" in out
    assert "model     lite (from firmware)\n" in out
    assert "battery   42 %\n" in out


def test_probe_a_simulate_process_as_in_the_readme(capsys: pytest.CaptureFixture[str]) -> None:
    sim = subprocess.Popen(
        [sys.executable, "-m", "xgo_show", "simulate", "--model", "rider", "--battery", "64"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert sim.stdout is not None
        path = sim.stdout.readline().strip()
        assert main(["probe", path, "--timeout", "2"]) == 0
    finally:
        sim.terminate()
        sim.wait(timeout=30)
    out = capsys.readouterr().out
    assert "model     rider (from firmware)\n" in out
    assert "battery   64 %\n" in out


def test_probe_given_model_that_firmware_contradicts(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["probe", "sim:lite", "--model", "mini"]) == 0
    assert "model     mini (given; the firmware names a lite)" in capsys.readouterr().out


def test_probe_unopenable_port_is_one_line_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["probe", "/dev/nonexistent"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == (
        "xgo-show: error: cannot open /dev/nonexistent: No such file or directory\n"
    )


def test_probe_silent_port_with_model(capsys: pytest.CaptureFixture[str]) -> None:
    master, slave = os.openpty()
    path = os.ttyname(slave)
    try:
        assert main(["probe", path, "--model", "xarm", "--timeout", "0.1"]) == 2
    finally:
        os.close(master)
        os.close(slave)
    assert capsys.readouterr().err == (
        f"xgo-show: error: no reply from {path} to a GetBatteryVoltage within 0.1 s\n"
    )


def test_probe_bad_timeout(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["probe", "sim:mini", "--timeout", "0"]) == 2
    assert "--timeout must be a positive" in capsys.readouterr().err


def test_probe_error_from_a_real_process_has_no_traceback() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "xgo_show", "probe", "/dev/nonexistent"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.splitlines() == [
        "xgo-show: error: cannot open /dev/nonexistent: No such file or directory"
    ]


def test_probe_silent_port_is_a_one_line_timeout(capsys: pytest.CaptureFixture[str]) -> None:
    # Without --model the probe asks for the XGO firmware string, which an xArm never sends.
    master, slave = os.openpty()  # nobody answers on the other end
    path = os.ttyname(slave)
    try:
        assert main(["probe", path, "--timeout", "0.1"]) == 2
    finally:
        os.close(master)
        os.close(slave)
    assert capsys.readouterr().err == (
        f"xgo-show: error: no reply from {path} to a read of firmware (0x07) within 0.1 s "
        "(for an xArm, give the model xarm)\n"
    )


_BAD_SHOW = """\
show: Bad
performers:
  rex: {model: mini}
  rio: {model: rider}
tracks:
  rex:
    - {move: {pitch: 10}, duration: -1}
  rio:
    - {led: {led9: red}}
    - {walk: {vx: 0.5, vy: 0.2}, duration: 2}
    - {move: {roll: 90}, duration: 1}
"""


@pytest.mark.parametrize("command", [["compile"], ["inspect"], ["dry-run", "--fast"]])
def test_a_bad_routine_lists_every_error_then_a_summary(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: list[str]
) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(_BAD_SHOW, encoding="utf-8")
    assert main([command[0], str(path), *command[1:]]) == 2
    err = capsys.readouterr().err.splitlines()
    assert [line.split(": error: ")[0] for line in err] == [
        f"{path}:7:37", f"{path}:9:14", f"{path}:10:28", f"{path}:11:21", "xgo-show",
    ]
    assert "(and" not in "\n".join(err)
    assert err[-1] == f"xgo-show: error: {path}: 4 error(s)"


def test_a_compile_error_lists_its_diagnostics(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "slow.yaml"
    path.write_text("show: S\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
                    "    - {move: {body_z: 100}, duration: 0.1}\n"
                    "    - {move: {body_z: 75}, duration: 0.1}\n", encoding="utf-8")
    assert main(["compile", str(path), "-o", str(path) + ".json"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 3, err
    assert err[0].startswith(f"{path}:6:7: error: ") and "needs at least" in err[0]
    assert err[1].startswith(f"{path}:7:7: error: ")
    assert err[2] == f"xgo-show: error: {path}: 2 error(s)"


def test_hex_prefix_logs_the_traffic_on_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["probe", "hex+sim:mini"]) == 0
    captured = capsys.readouterr()
    assert "firmware  M-1.4.1" in captured.out
    lines = captured.err.splitlines()
    # The firmware request (register 0x07) and its reply, as hexlog writes them.
    assert lines[0] == "sim:mini > 55 00 09 02 07 0a e3 00 aa"
    assert lines[1].startswith("sim:mini < 55 00 12 12 07 4d 2d 31")
    assert all(line.startswith(("sim:mini > 55 ", "sim:mini < 55 ")) for line in lines)


def test_plain_ports_log_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["probe", "sim:mini"]) == 0
    assert capsys.readouterr().err == ""


def test_inspect_lists_the_sections_and_the_triggers_they_wait_for(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # issue 10: inspect lists the triggers a routine uses, each wait with its timeout.
    routine = Path(__file__).resolve().parents[2] / "choreographies" / "curtain_call.yaml"
    assert main(["inspect", str(routine)]) == 0
    out = capsys.readouterr().out
    assert "trigger 'go'" in out
    assert "trigger 'encore', after 20 s: finale" in out
    assert out.endswith("triggers: go, encore\n")


def test_inspect_reads_a_schedule_by_its_content_whatever_its_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    show = tmp_path / "show.yaml"
    show.write_text("show: S\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
                    "    - {action: stand_up}\n", encoding="utf-8")
    schedule = tmp_path / "compiled.yaml"  # a schedule saved under a routine's name
    assert main(["compile", str(show), "-o", str(schedule), "-q"]) == 0
    capsys.readouterr()
    assert main(["inspect", str(schedule)]) == 0
    assert capsys.readouterr().out.startswith("S: 1 performer(s)")
    # run and dry-run read it the same way (one loader), not as a routine.
    assert main(["dry-run", str(schedule), "--fast"]) == 0
    assert "error" not in capsys.readouterr().err


def test_a_named_command_imports_only_its_own_module() -> None:
    # A fresh interpreter: which xgo_show.cli modules did 'validate --help' import?
    code = (
        "import sys\n"
        "from xgo_show.cli.main import main\n"
        "try:\n    main(['validate', '--help'])\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in sys.modules if m.startswith('xgo_show.cli.')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    loaded = out.strip().splitlines()[-1]
    assert "'xgo_show.cli.validate'" in loaded
    assert "'xgo_show.cli.run'" not in loaded and "'xgo_show.cli.inspect'" not in loaded


@pytest.mark.parametrize("argv", [["--help"], ["dry_run"], ["nonsense"]])
def test_without_a_command_every_command_is_registered(argv: list[str]) -> None:
    parser = build_parser(argv)
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert len(subparsers.choices) == len(COMMANDS)


def test_a_named_command_parses_as_with_every_command_registered() -> None:
    argv = ["dry-run", "choreographies/hello_mini.yaml", "--fast"]
    assert vars(build_parser(argv).parse_args(argv)) == vars(build_parser().parse_args(argv))


class _Exited(Exception):
    """os._exit, recorded instead of ending the test run."""


def _program(monkeypatch: pytest.MonkeyPatch, argv: list[str]) -> tuple[str, int]:
    """Run :func:`program` on ``argv``: how it ended ('os._exit' or 'sys.exit') and the status."""
    def _exit(code: int) -> None:
        raise _Exited(code, gc.isenabled())

    monkeypatch.setattr(os, "_exit", _exit)
    monkeypatch.setattr(sys, "argv", ["xgo-show", *argv])
    assert gc.isenabled()
    try:
        program()
    except _Exited as done:
        assert not done.args[1]  # a quick command runs without the cyclic collector
        return "os._exit", int(done.args[0])
    except SystemExit as done:
        assert gc.isenabled()
        return "sys.exit", int(done.code or 0)
    finally:
        gc.enable()
    raise AssertionError("program() returned")


def test_validate_and_compile_end_the_process_at_once_with_their_status(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(_BAD_SHOW, encoding="utf-8")
    good = tmp_path / "good.yaml"
    good.write_text("show: S\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
                    "    - {action: stand_up}\n", encoding="utf-8")
    assert _program(monkeypatch, ["validate", str(bad)]) == ("os._exit", 1)
    assert capsys.readouterr().out.splitlines()[-1] == f"{bad}: FAILED: 4 error(s), 0 warning(s)"
    assert _program(monkeypatch, ["compile", "-q", str(good), "-o", str(tmp_path / "o")]) == (
        "os._exit", 0)
    assert (tmp_path / "o").stat().st_size > 0
    assert _program(monkeypatch, ["compile", str(bad)]) == ("os._exit", 2)
    # Every other command exits as Python does (its threads, children and files finish).
    assert _program(monkeypatch, ["schema"]) == ("sys.exit", 0)


def test_a_thread_still_running_gets_the_usual_exit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    good = tmp_path / "good.yaml"
    good.write_text("show: S\nperformers:\n  rex: {model: mini}\ntracks:\n  rex:\n"
                    "    - {action: stand_up}\n", encoding="utf-8")
    release = threading.Event()
    other = threading.Thread(target=release.wait)  # not a daemon: Python's exit joins it
    other.start()
    try:
        assert _program(monkeypatch, ["validate", str(good)]) == ("sys.exit", 0)
    finally:
        release.set()
        other.join()
    assert "good.yaml: ok" in capsys.readouterr().out


def test_python_m_xgo_show_validate_writes_everything_before_it_exits(tmp_path: Path) -> None:
    # A real process, its output a pipe: the quick exit flushes what validate printed.
    bad = tmp_path / "bad.yaml"
    bad.write_text(_BAD_SHOW, encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "xgo_show", "validate", str(bad)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1
    lines = proc.stdout.splitlines()
    assert len(lines) == 5 and lines[0].startswith(f"{bad}:7:37: error: ")
    assert lines[-1] == f"{bad}: FAILED: 4 error(s), 0 warning(s)"
