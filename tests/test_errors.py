"""One exception tree: every failure has its class in xgo_show.errors, none raises the bare root."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import xgo_show
from xgo_show import errors
from xgo_show.diagnostics import Diagnostic, Origin

PACKAGE = Path(xgo_show.__file__).parent


def _modules() -> list[Path]:
    """Every module of the package: none is exempt."""
    return sorted(PACKAGE.rglob("*.py"))


def _names_root(node: ast.expr | None) -> bool:
    """``XgoShowError``, ``errors.XgoShowError``, called or not."""
    if isinstance(node, ast.Call):
        node = node.func
    return (isinstance(node, ast.Name) and node.id == "XgoShowError") or (
        isinstance(node, ast.Attribute) and node.attr == "XgoShowError")


def _base_name(node: ast.expr) -> str:
    if isinstance(node, ast.Name):
        return node.id
    return node.attr if isinstance(node, ast.Attribute) else ""


def test_every_public_class_is_an_xgo_show_error() -> None:
    for name in errors.__all__:
        cls = getattr(errors, name)
        assert issubclass(cls, errors.XgoShowError), name


def test_no_module_raises_the_bare_root_error() -> None:
    found = []
    for path in _modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Raise) and _names_root(node.exc):
                found.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert found == [], f"raise a subclass from xgo_show.errors instead: {found}"


def test_the_check_sees_every_spelling_of_a_bare_raise() -> None:
    for code in ("raise XgoShowError('x')", "raise errors.XgoShowError('x')", "raise XgoShowError"):
        raise_node = ast.parse(code).body[0]
        assert isinstance(raise_node, ast.Raise) and _names_root(raise_node.exc), code
    other = ast.parse("raise UsageError('x')").body[0]
    assert isinstance(other, ast.Raise) and not _names_root(other.exc)


def test_exception_classes_live_in_errors_py() -> None:
    found = []
    for path in _modules():
        if path.name == "errors.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and any(
                _base_name(b).endswith(("Error", "Exception", "Refused", "Fault"))
                for b in node.bases
            ):
                found.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {node.name}")
    assert found == []


@pytest.mark.parametrize(("module", "name", "target"), [
    ("xgo_show.runtime", "PreflightError", errors.PreflightError),
    ("xgo_show.runtime", "UnsafeScheduleError", errors.UnsafeScheduleError),
    ("xgo_show.runtime.preflight", "PreflightError", errors.PreflightError),
    ("xgo_show.runtime.safety", "UnsafeScheduleError", errors.UnsafeScheduleError),
    ("xgo_show.compiler.trajectory", "TrajectoryError", errors.TrajectoryError),
    ("xgo_show.compiler.trajectory", "InfeasibleMotion", errors.InfeasibleMotion),
    ("xgo_show.sim.base", "Rejected", errors.FrameRejected),
    ("xgo_show.net.timesync", "TimeSyncError", errors.TimeSyncError),
    ("xgo_show.audio.sink", "NoAudioDevice", errors.NoAudioDevice),
    ("xgo_show.control.director", "ControlError", errors.ControlError),
    ("xgo_show.control.client", "ControlFailed", errors.ControlFailed),
    ("xgo_show.net.messages", "MessageError", errors.MessageError),
    ("xgo_show.relay.validate", "UploadRefused", errors.UploadRefused),
])
def test_old_names_stay_importable(module: str, name: str, target: type) -> None:
    mod = __import__(module, fromlist=[name])
    assert getattr(mod, name) is target


def test_trajectory_errors_are_compile_errors_with_typed_diagnostics() -> None:
    exc = errors.InfeasibleMotion(2.5, 0, 1.0)
    assert isinstance(exc, errors.CompileError) and exc.diagnostics == ()
    d = Diagnostic("error", "bad", Origin("a.yaml", 3, 4))
    assert errors.ChoreographyError("x", (d,)).diagnostics[0].origin == Origin("a.yaml", 3, 4)


@pytest.mark.parametrize("cls", [errors.UsageError, errors.FileAccessError,
                                 errors.ScheduleError, errors.SetupError,
                                 errors.SimulatorError, errors.PlotError])
def test_new_classes_are_caught_as_the_root(cls: type[errors.XgoShowError]) -> None:
    with pytest.raises(errors.XgoShowError, match="boom"):
        raise cls("boom")
