"""Draw a schedule: every performer's register trajectories, actions and LED colours over time.

Values are decoded from the scheduled frames themselves (:func:`describe_frame`), so the plot
shows what goes on the wire, not what the routine asked for. Needs matplotlib (the optional
``plot`` extra), imported only when a plot is drawn.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from xgo_show.compiler.layout import ACTION_REGISTER
from xgo_show.compiler.schedule import PerformerSchedule, Schedule
from xgo_show.compiler.state import describe_frame, format_value
from xgo_show.errors import PlotError
from xgo_show.families import get_family
from xgo_show.profiles.model import Encoding, Profile
from xgo_show.profiles.registry import get_profile

__all__ = ["draw_xarm_panel", "draw_xgo_panel", "plot_schedule"]


def _pyplot() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise PlotError(
            "plotting needs matplotlib: pip install 'xgo-show[plot]' (or pip install matplotlib)"
        ) from exc
    return plt


def plot_schedule(schedule: Schedule, path: str | Path) -> Path:
    """Draw ``schedule`` into a PNG at ``path`` (one panel per performer); returns the path."""
    plt = _pyplot()
    rows = max(len(schedule.performers), 1)
    fig, axes = plt.subplots(rows, 1, figsize=(12, 3.2 * rows), squeeze=False, sharex=True)
    end = max(schedule.duration, 1e-3)
    for ax, performer in zip(axes[:, 0], schedule.performers, strict=False):
        profile = get_profile(performer.model)
        get_family(profile).plot_panel(ax, profile, performer, end)
        ax.set_title(f"{performer.name} ({profile.title})", loc="left", fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0, end)
    axes[-1, 0].set_xlabel("show time (s)")
    fig.suptitle(f"{schedule.name} — {schedule.control_rate:g} Hz", fontsize=12)
    fig.tight_layout()
    target = Path(path)
    try:
        fig.savefig(target, dpi=110)
    except OSError as exc:
        raise PlotError(f"cannot write plot {target}: {exc.strerror or exc}") from exc
    finally:
        plt.close(fig)
    return target


def draw_xgo_panel(ax: Any, profile: Profile, performer: PerformerSchedule, end: float) -> None:
    """An XGO performer's panel: register curves, preset actions, LED colour strips."""
    series: dict[str, tuple[list[float], list[float]]] = {}
    colours: dict[str, list[tuple[float, tuple[int, int, int]]]] = {}
    marks: list[tuple[float, str]] = []
    actions: list[tuple[float, float, str]] = []
    units = {r.name: r.unit or "" for r in profile.registers}
    encodings = {r.name: r.encoding for r in profile.registers}
    for frame in performer.frames:
        for name, value in describe_frame(profile, frame.data):
            if name == ACTION_REGISTER:
                actions.append((frame.t, frame.duration,
                                format_value(profile, name, value)))
            elif encodings.get(name) is Encoding.RGB and isinstance(value, tuple):
                colours.setdefault(name, []).append((frame.t, value))
            elif isinstance(value, float):
                ts, vs = series.setdefault(name, ([], []))
                ts.append(frame.t)
                vs.append(value)
            else:
                marks.append((frame.t, f"{name}={format_value(profile, name, value)}"))
    # A register that never changes (often one only re-sent to bridge a gap) is not drawn.
    series = {n: tv for n, tv in series.items() if min(tv[1]) != max(tv[1])}
    for name in sorted(series, key=lambda n: profile.register(n).address):
        ts, vs = series[name]
        ax.step([*ts, end], [*vs, vs[-1]], where="post", label=f"{name} ({units[name]})",
                linewidth=1.4)
    for t, duration, text in actions:
        ax.axvspan(t, t + max(duration, end / 400), color="tab:orange", alpha=0.18)
        ax.annotate(f"action {text}", (t, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(2, -10), textcoords="offset points", fontsize=7, color="tab:brown")
    for row, name in enumerate(sorted(colours)):
        points = colours[name]
        y = 0.02 + 0.045 * row
        for i, (t, rgb) in enumerate(points):
            t_next = points[i + 1][0] if i + 1 < len(points) else end
            ax.add_patch(_colour_bar(ax, t, t_next - t, y, rgb))
        ax.annotate(name, (1.0, y + 0.017), xycoords="axes fraction", fontsize=7,
                    xytext=(3, 0), textcoords="offset points", va="center")
    for t, text in marks:
        ax.axvline(t, color="grey", linewidth=0.6, linestyle=":")
        ax.annotate(text, (t, 0.0), xycoords=("data", "axes fraction"), rotation=90,
                    fontsize=6, xytext=(2, 4), textcoords="offset points", color="dimgrey",
                    va="bottom")
    if colours:
        # Room under the curves for the colour strips.
        low, high = ax.get_ylim()
        ax.set_ylim(low - (high - low) * 0.06 * (len(colours) + 1), high)
    if series:
        ax.legend(loc="upper right", fontsize=7, ncol=min(len(series), 4))
    ax.set_ylabel("physical value")


def _colour_bar(ax: Any, t: float, width: float, y: float, rgb: tuple[int, int, int]) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle(
        (t, y), width, 0.035, transform=ax.get_xaxis_transform(),
        facecolor=tuple(c / 255 for c in rgb), linewidth=0,
    )


def draw_xarm_panel(ax: Any, performer: PerformerSchedule, end: float) -> None:
    """An xArm performer's panel: each servo's target position, moving over each ServoMove."""
    profile = get_profile(performer.model)
    tracks: dict[str, tuple[list[float], list[float]]] = {}
    for frame in performer.frames:
        fields = dict(describe_frame(profile, frame.data))
        duration = float(fields.pop("time_ms", 0)) / 1000  # type: ignore[arg-type]
        for name, pos in fields.items():
            ts, vs = tracks.setdefault(name, ([], []))
            if ts:
                ts.append(frame.t)
                vs.append(vs[-1])
            ts.append(frame.t + duration)
            vs.append(float(pos))  # type: ignore[arg-type]
    for name in sorted(tracks):
        ts, vs = tracks[name]
        ax.plot([*ts, end], [*vs, vs[-1]], label=name, linewidth=1.4)
    if tracks:
        ax.legend(loc="upper right", fontsize=7, ncol=min(len(tracks), 6))
    ax.set_ylabel("servo position (0..1000)")
