"""Expand a validated routine into the resolved show: absolute seconds, physical values.

Tempo, bar/beat positions, phrases (with parameters), repeats and includes are expanded away.
Every problem found on the way becomes a diagnostic; resolution carries on past it so that one
run reports everything. Register-level checks (names, ranges, capabilities) and timing conflicts
are left to :mod:`xgo_show.choreo.checks`, which reads the :class:`CueSource` kept per cue.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from xgo_show.choreo.colors import parse_color
from xgo_show.choreo.model import (
    ActionCueModel,
    ArmCueModel,
    CueList,
    GripperCueModel,
    IncludeCueModel,
    LedCueModel,
    Length,
    MoveCueModel,
    ParamPartMapping,
    PartMapping,
    PerformerModel,
    PeriodicCueModel,
    PhraseCueModel,
    PhraseModel,
    PoseCueModel,
    PoseDegCueModel,
    Position,
    RepeatCueModel,
    RestCueModel,
    SetCueModel,
    ShowFile,
    TempoConstant,
    TempoEntry,
    TempoFile,
    TempoMapFile,
    WalkCueModel,
    cue_kind,
)
from xgo_show.choreo.music import Music
from xgo_show.choreo.resolved import (
    ActionCue,
    ArmCue,
    Cue,
    FadeCue,
    MotionCue,
    ResolvedShow,
    ResolvedTrack,
    SetCue,
)
from xgo_show.choreo.section_rules import resolve_sections
from xgo_show.choreo.source import MAX_NODES, Document, Loc, parse_yaml, read_text
from xgo_show.choreo.timebase import Segment, TempoMap
from xgo_show.choreo.validation import Suggestions, validate
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.errors import ProfileError, ValueRangeError
from xgo_show.families import get_family
from xgo_show.files import MAX_ROUTINE_BYTES, file_problem
from xgo_show.limits import MAX_PERFORMERS, MAX_SHOW_SECONDS
from xgo_show.profiles import Encoding, Limits, Profile, Register, get_profile
from xgo_show.profiles.xarm import degrees_to_position

if TYPE_CHECKING:
    from xgo_show.choreo.params import Argument
    from xgo_show.choreo.salvage import Salvage

__all__ = [
    "MAX_BLOCK_DEPTH", "MAX_CUES", "MAX_SAMPLES", "MAX_SECONDS", "CueSource", "Resolution",
    "resolve_show",
]

_STAND_IN_TEMPO = TempoMap.constant(120.0, 4)  # times of a show that forgot its tempo
MAX_CUES = 20_000  # a guard against repeat blocks that expand to absurd sizes
#: Samples the compiler may take for a show: every second of a move costs control_rate
#: samples, a fade (per LED) as many as its colour steps at most. Each costs some 10 us of
#: planning and encoding, so this keeps compiling (and validating) any routine to seconds:
#: ten minutes of ten robots moving without a pause at 50 Hz need 420,000. A show past it is
#: refused at the cue that passes it, before any sampling is done.
MAX_SAMPLES = 500_000
# The most samples one fade takes: its colour changes at most 255 times in each channel.
_FADE_STEPS = 3 * 256
MAX_SECONDS = MAX_SHOW_SECONDS  # a show longer than an hour is a typo (or needs splitting)
#: Includes within includes at most this deep: a real routine nests two or three; deeper is a
#: generated chain, reported at the include that passes it rather than at 1:1 when Python's
#: recursion limit is hit.
MAX_NESTING = 32
#: Blocks (repeats, phrases, includes) within blocks at most this deep. Repeats nest only as
#: deep as the YAML does, but a phrase that plays a phrase that plays a phrase... chains by
#: name, with no YAML nesting at all: a real routine nests three or four, and each level
#: costs the resolver some stack, so a generated chain of hundreds is refused at the cue that
#: passes the limit (rather than at 1:1 when Python's recursion limit is hit).
MAX_BLOCK_DEPTH = 64


_V = TypeVar("_V")


class _Located(Mapping[str, _V]):
    """Per value of a cue, its place (origin or field path), worked out when asked for: the
    checks ask only about the values they report on, a handful among 10^5."""

    __slots__ = ("_locs", "_place")

    def __init__(self, locs: Mapping[str, Loc], place: Callable[[Loc], _V]) -> None:
        self._locs = locs
        self._place = place

    def __getitem__(self, key: str) -> _V:
        return self._place(self._locs[key])

    def __iter__(self) -> Iterator[str]:
        return iter(self._locs)

    def __len__(self) -> int:
        return len(self._locs)


class CueSource:
    """Where a resolved cue came from, for the checks and their messages (one per cue of the
    show: a plain class, its field path worked out only when a message asks for it)."""

    __slots__ = ("_doc", "_loc", "end", "kind", "origin", "paths", "performer", "running",
                 "values")

    def __init__(
        self, performer: str, kind: str, doc: Document, loc: Loc, origin: Origin,
        values: Mapping[str, Origin], paths: Mapping[str, str], running: float, end: float,
    ) -> None:
        self.performer = performer
        self.kind = kind  # the language's cue kind (move, walk, set, ...)
        self._doc, self._loc = doc, loc
        self.origin = origin
        self.values = values  # per register / servo key
        self.paths = paths  # field path of each value
        self.running = running  # seconds the robot is busy with it (actions: their run time)
        self.end = end  # end of the cue's slot, seconds (estimated for open-ended moves)

    @property
    def path(self) -> str:
        """The field path of the cue, e.g. ``tracks.rex[3]``."""
        return self._doc.path(self._loc)


@dataclass
class Resolution:
    """The result of :func:`resolve_show`: a show (when no errors) and every diagnostic."""

    show: ResolvedShow | None
    diagnostics: list[Diagnostic]
    sources: dict[int, CueSource]  # id(cue) -> source
    performers: dict[str, PerformerModel]
    untimed: frozenset[str] = frozenset()  # performers whose cue times are not known


    def source(self, cue: Cue) -> CueSource:
        return self.sources[id(cue)]


@dataclass(frozen=True)
class _Phrase:
    name: str
    model: PhraseModel
    doc: Document
    loc: Loc


_Part = CueList | PartMapping | ParamPartMapping  # an included file, parsed


@dataclass(frozen=True)
class _Body:
    """Cues played with parameters: a phrase's, or a part file's with ``params:``."""

    title: str  # for messages: "phrase 'nod'", "parts/a.yaml"
    label: str  # for field paths: "phrase nod", "include parts/a.yaml"
    params: Mapping[str, object]  # name -> default (None: must be given)
    doc: Document
    base: Loc  # the block's own place in doc (paths inside it read relative to it)


@dataclass
class _Block:
    """Where a list of cues is being resolved."""

    doc: Document
    loc: Loc  # of the cue list
    start: float  # seconds: the block's own zero
    top: bool  # a performer's track itself (bar/beat are then absolute)
    phrases: Mapping[str, _Phrase]
    includes: tuple[Path, ...]  # files being included, for cycle detection
    context: str = ""  # "phrase nod at 12:5", for cue descriptions


@dataclass
class _Performer:
    name: str
    model: PerformerModel
    profile: Profile
    state: dict[str, float]  # last known register values, for open-ended move estimates
    cues: list[Cue] = field(default_factory=list)


class _Resolver:
    def __init__(self, show: ShowFile, doc: Document, salvage: Salvage | None = None) -> None:
        self.show = show
        self.doc = doc
        self.salvage = salvage
        self.diags: list[Diagnostic] = []
        self.sources: dict[int, CueSource] = {}
        self.tempo: TempoMap | None = None
        self.parts: dict[Path, tuple[Document | None, _Part | None, str]] = {}
        self.count = 0
        self.too_many = False
        self.no_tempo = False  # bars or beats were used without a tempo (see need_tempo)
        self.phrase_stack: list[str] = []
        self.suggest = Suggestions()  # did-you-mean hints, bounded in number
        self.blocks: list[str] = []  # the blocks being played, outermost first
        self.cut = False  # a chain too deep was not played: what it plays is not unused
        self.samples = 0.0  # trajectory and fade samples the compiler will take (see add)
        self.emitted = 0  # cues made for the compiler (a path's segments each count)
        self.expanded = 0  # values of the blocks played, parameters filled in, at each play
        self.played: set[tuple[str, str]] = set()  # (file, phrase) actually played
        self.by_name: dict[int, dict[str, Register]] = {}  # id(profile) -> its registers
        self.by_led: dict[int, list[str]] = {}  # id(profile) -> its LEDs' names
        self.read_bytes = _size(doc.file)  # of the routine and the parts read so far

    def registers(self, profile: Profile) -> dict[str, Register]:
        """The profile's registers by name (looked up for every value of the show)."""
        found = self.by_name.get(id(profile))
        if found is None:
            found = self.by_name[id(profile)] = {r.name: r for r in profile.registers}
        return found

    def leds(self, profile: Profile) -> list[str]:
        """The names of the profile's LEDs (RGB registers), in its order."""
        found = self.by_led.get(id(profile))
        if found is None:
            found = self.by_led[id(profile)] = [
                r.name for r in profile.registers if r.encoding is Encoding.RGB]
        return found

    # -- diagnostics ----------------------------------------------------------------------

    def error(self, doc: Document, loc: Loc, message: str, *, key: bool = False) -> None:
        self.diags.append(Diagnostic("error", message, doc.origin(loc, key=key), doc.path(loc)))

    def warning(self, doc: Document, loc: Loc, message: str) -> None:
        self.diags.append(Diagnostic("warning", message, doc.origin(loc), doc.path(loc)))

    # -- time -----------------------------------------------------------------------------

    def need_tempo(self, doc: Document, loc: Loc, what: str) -> TempoMap | None:
        """The show's tempo; without one, an error here and a stand-in tempo, so that the rest
        of the cue (its values, its kind) is still checked: one error hides no other. Times
        are then guesses, so the timing checks are skipped (every performer is untimed)."""
        broken = self.show.tempo is not None or bool(self.salvage and self.salvage.tempo_broken)
        if self.tempo is None and broken:  # reported where the tempo is written
            self.no_tempo = True
            return _STAND_IN_TEMPO
        if self.tempo is None:
            self.error(doc, loc, f"{what} need a tempo: add e.g. 'tempo: {{bpm: 120}}' to the show")
            self.no_tempo = True
            return _STAND_IN_TEMPO
        return self.tempo

    def position(self, pos: Position, block: _Block, loc: Loc) -> float | None:
        if pos.seconds is not None:
            if pos.bare and self.tempo is not None:
                amount = f"{pos.seconds:g}"
                self.warning(block.doc, loc, f"at: {amount} is {amount} seconds, not a bar (the "
                             f"show has a tempo): for bar {int(pos.seconds) or 1} write "
                             f"\"{int(pos.seconds) or 1}.1\"; to keep seconds, write "
                             f"\"{amount}s\"")
            return block.start + pos.seconds
        assert pos.bar is not None
        tempo = self.need_tempo(block.doc, loc, "bar/beat times")
        if tempo is None:
            return None
        try:
            if block.top:
                return tempo.position(pos.bar, pos.beat)
            # Inside a phrase, repeat or include: count bars from the block's start, in the
            # meter in force there.
            per_bar = tempo.beats_per_bar_at(block.start)
            if pos.beat >= per_bar + 1:
                raise ValueError(f"beat {pos.beat:g} is outside a bar of {per_bar} beats")
            beats = tempo.beats(block.start) + (pos.bar - 1) * per_bar + (pos.beat - 1)
            return tempo.seconds(beats)
        except ValueError as exc:
            self.error(block.doc, loc, str(exc))
            return None

    def length(self, value: Length, start: float, doc: Document, loc: Loc) -> float | None:
        if value.unit == "seconds":
            return value.amount
        tempo = self.need_tempo(doc, loc, value.unit)
        if tempo is None:
            return None
        beats = value.amount
        if value.unit == "bars":
            beats *= tempo.beats_per_bar_at(start)
        return tempo.span(start, beats)

    def cue_length(
        self, cue: object, start: float, doc: Document, loc: Loc
    ) -> tuple[bool, float | None]:
        """(given, seconds) from duration / beats / bars; (False, None) when none is given."""
        duration = getattr(cue, "duration", None)
        if duration is not None:  # seconds as they are (what length() would give)
            return True, duration
        for name, unit in (("beats", "beats"), ("bars", "bars")):
            amount = getattr(cue, name, None)
            if amount is not None:
                return True, self.length(Length(amount, unit), start, doc, (*loc, name))  # type: ignore[arg-type]
        return False, None

    # -- entry ----------------------------------------------------------------------------

    def run(self) -> Resolution:
        show, doc = self.show, self.doc
        self.tempo = self.build_tempo()
        phrases = self.collect_phrases()
        performers: dict[str, _Performer] = {}
        if len(show.performers) > MAX_PERFORMERS:
            self.error(doc, ("performers",), f"{len(show.performers)} performers: a show drives "
                       f"at most {MAX_PERFORMERS}", key=True)
        ports: dict[str, str] = {}
        for name, perf in show.performers.items():
            if perf.port is not None and perf.port in ports:
                self.error(doc, ("performers", name, "port"),
                           f"{name} and {ports[perf.port]} are both on port {perf.port!r}: one "
                           "robot per port")
            elif perf.port is not None:
                ports[perf.port] = name
            profile = get_profile(perf.model)
            if perf.arm and not profile.supports("arm"):
                self.error(doc, ("performers", name, "arm"),
                           f"'arm: true' is for the XGO-Mini and XGO-Lite; the {profile.title} "
                           "has no arm accessory")
            performers[name] = _Performer(name, perf, profile, _initial_state(profile))
        self.check_timed_by_hand([p.profile for p in performers.values()])
        for name, cues in show.tracks.items():
            if not cues and name in performers:
                self.warning(doc, ("tracks", name), f"the track of {name} is empty: "
                             f"{name} does nothing in this show")
            if name not in performers:
                hint = self.suggest(name, list(performers))
                self.error(doc, ("tracks", name),
                           f"no performer named {name!r}{hint}; performers: "
                           f"{', '.join(performers)}", key=True)
                continue
            block = _Block(doc, ("tracks", name), 0.0, True, phrases, (Path(doc.file).resolve(),))
            self.sequence(performers[name], cues, block)
        salvage = self.salvage  # parts were cut away: what looks unused may not be
        for phrase in phrases.values():
            unplayed = (phrase.doc.file, phrase.name) not in self.played
            if unplayed and salvage is None and not self.cut:
                self.warning(phrase.doc, phrase.loc, f"phrase {phrase.name!r} is never played")
        for name in performers:
            if name not in show.tracks and salvage is None:
                self.warning(doc, ("performers", name), f"performer {name!r} has no track")
        untimed = frozenset(salvage.untimed if salvage else ())
        if self.no_tempo:
            untimed |= frozenset(performers)
        end = None
        if show.settings.end is not None:
            top = _Block(doc, ("settings",), 0.0, True, phrases, ())
            end = self.position(show.settings.end, top, ("settings", "end"))
        if end is not None:
            for player in performers.values():
                if player.name in untimed:
                    continue
                late = [c for c in player.cues if self.sources[id(c)].end > end + 1e-9]
                if late:  # its frames would go out after the end: say so, do not cut them
                    src = self.sources[id(late[0])]
                    self.diags.append(Diagnostic(
                        "error", f"{player.name}: this cue ends at {src.end:.3f} s, after the "
                        f"show's end at {end:.3f} s (settings.end): move the end or the cue",
                        src.origin, src.path))
        show_end = end
        if show_end is None and not untimed:
            show_end = max((src.end for src in self.sources.values()), default=0.0)
        top = _Block(doc, (), 0.0, True, phrases, ())
        sections = resolve_sections(
            show, doc, lambda pos, loc: self.position(pos, top, loc), show_end, self.diags
        )
        tracks = tuple(
            ResolvedTrack(p.name, p.model.model, tuple(sorted(p.cues, key=lambda c: c.start)),
                          p.model.port)
            for p in performers.values()
            if p.name in show.tracks
        )
        first = self.tempo.segments[0] if self.tempo else None
        resolved = ResolvedShow(
            name=show.show,
            source=doc.file,
            tracks=tracks,
            control_rate=show.settings.control_rate,
            gap=None if show.settings.gap_ms is None else show.settings.gap_ms / 1000.0,
            decimate=show.settings.decimate,
            on_failure=show.settings.on_failure,
            battery_floor=show.settings.battery_floor,
            end=end,
            bpm=first.bpm if first else None,
            beats_per_bar=first.beats_per_bar if first else 4,
            tempo_map=tuple(
                (seg.bar, seg.bpm, seg.beats_per_bar)
                for seg in (self.tempo.segments if self.tempo else ())
            ),
            sections=sections,
            music=self.build_music(),
        )
        return Resolution(resolved, self.diags, self.sources,
                          {n: p.model for n, p in performers.items()}, untimed)

    def check_timed_by_hand(self, profiles: Sequence[Profile]) -> None:
        """settings.timed_by_hand names actions without a documented duration on some
        performer's robot: a misspelt name would silence nothing, silently."""
        untimed = sorted({a.name for p in profiles for a in p.actions if a.duration is None})
        for i, name in enumerate(self.show.settings.timed_by_hand):
            if name not in untimed:
                hint = self.suggest(name, untimed)
                valid = ", ".join(untimed) or "none in this show"
                self.error(self.doc, ("settings", "timed_by_hand", i),
                           f"{name!r} is not an action without a documented duration on any "
                           f"performer's robot{hint}; those are: {valid}")

    def build_music(self) -> Music | None:
        """``music:``: the recording must exist (it is decoded only when played)."""
        music = self.show.music
        if music is None:
            return None
        try:
            path = (Path(self.doc.file).parent / music.file).resolve()
        except (OSError, ValueError) as exc:  # a symlink loop, a NUL in the name
            problem: str | None = f"cannot read: {exc}"
        else:
            problem = file_problem(path)  # never opens a pipe or a device for long
        if problem == "no such file":
            self.error(self.doc, ("music", "file"), f"no such sound file: {music.file}")
            return None
        if problem is not None:
            self.error(self.doc, ("music", "file"), f"the sound file {music.file}: {problem}")
            return None
        return Music(music.file, str(path), music.offset)

    def build_tempo(self) -> TempoMap | None:
        tempo = self.show.tempo
        doc, loc = self.doc, ("tempo",)
        if tempo is None:
            return None
        if isinstance(tempo, TempoFile):
            loaded = self.load_tempo_file(tempo.file)
            if loaded is None:
                return None
            tempo, doc = loaded
        if isinstance(tempo, list):
            segments: list[Segment] = []
            per_bar = 4
            for i, entry in enumerate(tempo):
                per_bar = entry.beats_per_bar or per_bar
                segments.append(Segment(entry.bar, entry.bpm, per_bar))
                if i and entry.bar <= tempo[i - 1].bar:  # at the entry that repeats a bar
                    self.error(doc, (*loc, i, "bar"), "tempo map bars must increase: bar "
                               f"{entry.bar} after bar {tempo[i - 1].bar}")
                    return None
        else:
            segments = [Segment(1, tempo.bpm, tempo.beats_per_bar)]
        try:
            return TempoMap(segments)
        except ValueError as exc:
            self.error(doc, loc, str(exc))
            return None

    def load_tempo_file(
        self, name: str
    ) -> tuple[TempoConstant | list[TempoEntry], Document] | None:
        """``tempo: {file: NAME}``: the file's own ``tempo:``, errors at its lines."""
        loc: Loc = ("tempo", "file")
        try:
            path = Path(self.doc.file).parent / name
            text = read_text(path)
        except (OSError, ValueError) as exc:
            text = (str(exc),)
        if isinstance(text, tuple):
            self.error(self.doc, loc, f"cannot read the tempo map {name!r}: {text[0]}")
            return None
        if isinstance(text, Diagnostic):  # a byte that is not UTF-8, at its place
            self.diags.append(text)
            return None
        tdoc, errors = parse_yaml(text, str(path))
        model = None
        if not errors:
            model, errors = validate(TempoMapFile, tdoc, tdoc.data)
        self.diags.extend(errors)
        if model is None:
            if not errors:
                self.error(self.doc, loc, f"{name}: not a tempo map")
            return None
        return model.tempo, tdoc

    def collect_phrases(self) -> dict[str, _Phrase]:
        phrases: dict[str, _Phrase] = {}
        for i, include in enumerate(self.show.include):
            loc: Loc = ("include", i)
            part = self.load_part(include, self.doc, loc, (Path(self.doc.file).resolve(),))
            if part is None:
                continue
            pdoc, pmodel, _ = part
            if isinstance(pmodel, (PartMapping, ParamPartMapping)):
                for name in ("params", "cues"):
                    if name in pmodel.model_fields_set and getattr(pmodel, name):
                        self.error(pdoc, (name,),
                                   "a phrase library (the show's 'include:') holds phrases only; "
                                   "play cues with a cue {include: FILE} in a track")
                self.add_phrases(phrases, pmodel.phrases, pdoc, ("phrases",))
            else:
                self.error(self.doc, loc, f"{include} is a list of cues; the show's 'include:' "
                           "takes phrase libraries (a file with 'phrases:')")
        self.add_phrases(phrases, self.show.phrases, self.doc, ("phrases",))
        return phrases

    def add_phrases(
        self, into: dict[str, _Phrase], new: Mapping[str, PhraseModel], doc: Document, loc: Loc
    ) -> None:
        for name, model in new.items():
            if name in into:
                first = into[name].doc.origin((*into[name].loc,), key=True)
                self.error(doc, (*loc, name), f"phrase {name!r} is already defined at "
                           f"{first.file}:{first.line}", key=True)
                continue
            into[name] = _Phrase(name, model, doc, (*loc, name))

    # -- sequences ------------------------------------------------------------------------

    def sequence(self, perf: _Performer, cues: Sequence[object], block: _Block) -> float:
        """Resolve a list of cues one after another; returns the end of the last one."""
        cursor = block.start
        for i, cue in enumerate(cues):
            if self.too_many:
                break
            loc: Loc = (*block.loc, i)
            kind = cue_kind(cue) or "cue"
            start = cursor
            at, after = getattr(cue, "at", None), getattr(cue, "after", None)
            if (at is not None and at.seconds is not None
                    and not (at.bare and self.tempo is not None)):
                start = block.start + at.seconds  # what position() gives, without a call
            elif at is not None:
                t = self.position(at, block, (*loc, "at"))
                start = cursor if t is None else t
            elif after is not None:
                gap = self.length(after, cursor, block.doc, (*loc, "after"))
                start = cursor + (gap or 0.0)
            if start > MAX_SECONDS:
                self.too_long(block.doc, loc, start)
                break
            end = self.dispatch(perf, kind, cue, start, block, loc)
            cursor = start if end is None else end
            if cursor > MAX_SECONDS:
                self.too_long(block.doc, loc, cursor)
                break
        return cursor

    def too_long(self, doc: Document, loc: Loc, t: float) -> None:
        if not self.too_many:
            self.error(doc, loc, f"this cue ends at {t:g} s: a show lasts at most "
                       f"{MAX_SECONDS:g} s (check durations and repeat counts)")
        self.too_many = True

    def dispatch(
        self, perf: _Performer, kind: str, cue: object, start: float, block: _Block, loc: Loc
    ) -> float | None:
        # Every cue played counts, whatever its kind: nested repeats of zero-length rests
        # (or of empty phrases) take no time and emit nothing, but still cost their expansion.
        self.count += 1
        if self.count > MAX_CUES:
            self.too_many = True
            self.error(block.doc, loc, f"the show expands to more than {MAX_CUES:,} cues "
                       "(rests, repeats, phrases and includes counted at each play); check "
                       "the repeat counts")
            return None
        if isinstance(cue, RestCueModel):
            return start + (self.length(cue.rest, start, block.doc, (*loc, "rest")) or 0.0)
        if isinstance(cue, (RepeatCueModel, PhraseCueModel, IncludeCueModel)):
            label = (f"phrase {cue.phrase}" if isinstance(cue, PhraseCueModel) else
                     f"include {cue.include}" if isinstance(cue, IncludeCueModel) else "repeat")
            if len(self.blocks) >= MAX_BLOCK_DEPTH:
                chain = [*self.blocks[:3], "...", *self.blocks[-2:], label]
                self.cut = True
                self.error(block.doc, (*loc, kind), f"blocks nest more than {MAX_BLOCK_DEPTH} "
                           f"deep here ({' -> '.join(chain)}): flatten the chain of phrases, "
                           "repeats and includes")
                return None
            self.blocks.append(label)
            try:
                return self.block(perf, cue, start, block, loc)
            finally:
                self.blocks.pop()
        origin = block.doc.origin(loc, _describe(perf.name, kind, cue, block.context))
        emit = _Emitter(self, perf, kind, block, loc, origin)
        return emit.cue(cue, start)

    def block(
        self, perf: _Performer, cue: RepeatCueModel | PhraseCueModel | IncludeCueModel,
        start: float, block: _Block, loc: Loc,
    ) -> float | None:
        """Play a repeat, a phrase or an include: the end of what it played."""
        if isinstance(cue, RepeatCueModel):
            cursor = start
            for _ in range(cue.repeat):
                sub = _Block(block.doc, (*loc, "cues"), cursor, False, block.phrases,
                             block.includes, block.context)
                cursor = self.sequence(perf, cue.cues, sub)
                if self.too_many:
                    break
            return cursor
        if isinstance(cue, PhraseCueModel):
            return self.phrase(perf, cue, start, block, loc)
        return self.include(perf, cue, start, block, loc)

    def phrase(
        self, perf: _Performer, cue: PhraseCueModel, start: float, block: _Block, loc: Loc
    ) -> float | None:
        doc = block.doc
        found = block.phrases.get(cue.phrase)
        lost = self.salvage and (self.salvage.phrases_incomplete
                                 or cue.phrase in self.salvage.broken_phrases)
        if found is None and lost:
            return None  # its definition had errors of its own, reported already
        if found is None:
            names = list(block.phrases)
            listing = f"; phrases: {', '.join(names)}" if names else "; no phrases are defined"
            self.error(doc, (*loc, "phrase"), f"unknown phrase {cue.phrase!r}"
                       f"{self.suggest(cue.phrase, names)}{listing}")
            return None
        self.played.add((found.doc.file, found.name))
        if cue.phrase in self.phrase_stack:
            chain = " -> ".join([*self.phrase_stack, cue.phrase])
            self.error(doc, (*loc, "phrase"), f"phrase {cue.phrase!r} plays itself ({chain})")
            return None
        body = _Body(f"phrase {cue.phrase!r}", f"phrase {cue.phrase}", found.model.params,
                     found.doc, found.loc)
        bound = self.bind(body, cue.with_, doc, loc, (*loc, "phrase"))
        if bound is None:
            return None
        inst, parsed = bound
        here = doc.origin(loc)
        where = f"line {here.line}" if here.file == found.doc.file else f"{here.file}:{here.line}"
        sub = _Block(inst, (*found.loc, "cues"), start, False, block.phrases, block.includes,
                     f"phrase {cue.phrase} at {where}")
        self.phrase_stack.append(cue.phrase)
        try:
            return self.sequence(perf, parsed.cues, sub)
        finally:
            self.phrase_stack.pop()

    def bind(
        self, body: _Body, given: Mapping[str, object], doc: Document, loc: Loc, name_loc: Loc
    ) -> tuple[Document, CueList] | None:
        """Check a call's ``with:`` against ``body``'s parameters, put the values into its cues
        and validate them: the instance's document (a view linking each filled-in node to its
        value) and cues, or None after reporting why not."""
        from xgo_show.choreo.params import Argument, substitute  # for phrases and parts alone

        args: dict[str, Argument] = {}
        ok = True
        names = list(body.params)
        for name, value in given.items():
            if name not in body.params:
                listing = ", ".join(names) or "none"
                if not names and body.label.startswith("include"):
                    listing += " (a part file declares them under params:)"
                self.error(doc, (*loc, "with", name), f"{body.title} has no parameter {name!r}"
                           f"{self.suggest(name, names)}; parameters: {listing}", key=True)
                ok = False
                continue
            args[name] = Argument(value, doc, (*loc, "with", name))
        for name, default in body.params.items():
            if name in args:
                continue
            if default is None:
                self.error(doc, name_loc, f"{body.title} needs parameter {name!r} "
                           f"(with: {{{name}: ...}})")
                ok = False
            else:
                args[name] = Argument(default, body.doc, (*body.base, "params", name))
        if not ok:
            return None
        cues_loc: Loc = (*body.base, "cues")
        done = substitute(_lookup(body.doc.data, cues_loc), args, at=cues_loc,
                          label=body.label, base=body.base, owner=body.title)
        # A parameter's value is copied into each play, as a YAML alias is at each use: a
        # list of thousands of points passed to a phrase played thousands of times would be
        # built (and checked) millions of times. Count the values, as the YAML reader does.
        self.expanded += _values(done.data)
        if self.expanded > MAX_NODES:
            if not self.too_many:
                self.error(doc, name_loc, f"the phrases and parts played expand to more than "
                           f"{MAX_NODES:,} values (each parameter counted at each play): "
                           "pass smaller values, or play them fewer times")
            self.too_many = True
            return None
        inst = body.doc.view(links={**body.doc.links, **done.links})
        for where, message, key in done.problems:
            self.error(inst, where, message, key=key)
        parsed, diags = validate(CueList, inst, done.data, cues_loc, wrap="cues")
        reported = {inst.origin(where) for where, _, _ in done.problems}
        self.diags.extend(d for d in diags if d.origin not in reported)
        if parsed is None or done.problems:
            return None
        return inst, parsed

    def include(
        self, perf: _Performer, cue: IncludeCueModel, start: float, block: _Block, loc: Loc
    ) -> float | None:
        via = f"{block.doc.path(loc)} -> include {cue.include}"
        part = self.load_part(cue.include, block.doc, (*loc, "include"), block.includes, via)
        if part is None:
            return None
        pdoc, pmodel, path = part
        pdoc = pdoc.view(via=via)
        phrases = dict(block.phrases)
        cues_loc: Loc = ()
        if not isinstance(pmodel, CueList):
            self.add_phrases(phrases, pmodel.phrases, pdoc, ("phrases",))
            cues_loc = ("cues",)
        params = pmodel.params if isinstance(pmodel, ParamPartMapping) else {}
        body = _Body(cue.include, f"include {cue.include}", params, pdoc, ())
        cues: Sequence[object] = pmodel.cues
        if isinstance(pmodel, ParamPartMapping):
            bound = self.bind(body, cue.with_, block.doc, loc, (*loc, "include"))
            if bound is None:
                return None
            pdoc, parsed = bound
            cues = parsed.cues
        elif cue.with_:
            self.bind(body, cue.with_, block.doc, loc, (*loc, "include"))  # reports each one
            return None
        sub = _Block(pdoc, cues_loc, start, False, phrases, (*block.includes, path),
                     block.context)
        return self.sequence(perf, cues, sub)

    def load_part(
        self, name: str, doc: Document, loc: Loc, stack: tuple[Path, ...], via: str = ""
    ) -> tuple[Document, _Part, Path] | None:
        """Read, parse and validate an included file (once; later uses hit the cache).

        ``via`` names the first include in the field paths of the file's own errors.
        """
        try:  # realpath: a symlink loop is left for the read to report, not raised here
            path = Path(os.path.realpath(Path(doc.file).parent / name))
        except (OSError, ValueError) as exc:  # a NUL in the name, ...
            self.error(doc, loc, f"cannot include {name!r}: {exc}")
            return None
        if path in stack:
            chain = " -> ".join(p.name for p in (*stack, path))
            self.error(doc, loc, f"include cycle: {chain}")
            return None
        if len(stack) > MAX_NESTING:  # the stack starts with the routine itself
            self.error(doc, loc, f"includes nest more than {MAX_NESTING} deep here (from "
                       f"{stack[0].name}): include the parts from fewer levels")
            return None
        if path not in self.parts:
            self.parts[path] = self.parse_part(path, str(Path(doc.file).parent / name), via)
        pdoc, model, problem = self.parts[path]
        if problem:
            self.error(doc, loc, f"cannot include {name!r}: {problem}")
            return None
        assert pdoc is not None and model is not None
        return pdoc, model, path

    def parse_part(
        self, path: Path, shown: str, via: str
    ) -> tuple[Document | None, _Part | None, str]:
        text = read_text(path)
        if isinstance(text, tuple):
            return None, None, text[0]
        if isinstance(text, str):
            # Each part is read once, but a routine may include many: the routine and its
            # parts share the one budget of a routine's size.
            self.read_bytes += len(text.encode())
            if self.read_bytes > MAX_ROUTINE_BYTES:
                return None, None, (f"the routine and the parts it includes pass "
                                    f"{MAX_ROUTINE_BYTES:,} bytes together: include fewer or "
                                    "smaller parts")
        if isinstance(text, Diagnostic):  # a byte that is not UTF-8: at its place
            assert text.origin is not None
            self.diags.append(replace(text, origin=replace(text.origin, file=shown)))
            return None, None, "it has 1 error(s)"
        pdoc, errors = parse_yaml(text, shown)
        model: _Part | None = None
        if not errors:
            seen = pdoc.view(via=via)
            if isinstance(pdoc.data, list):
                model, errors = validate(CueList, seen, pdoc.data, (), wrap="cues")
            elif isinstance(pdoc.data, dict) and "params" in pdoc.data:
                model, errors = validate(ParamPartMapping, seen, pdoc.data)
            elif isinstance(pdoc.data, dict):
                model, errors = validate(PartMapping, seen, pdoc.data)
            else:
                return None, None, "it must hold a list of cues or a mapping with phrases/cues"
        self.diags.extend(errors)
        if errors:
            return None, None, f"it has {len(errors)} error(s)"
        return pdoc, model, ""


def _size(file: str) -> int:
    """Bytes of the file a document was read from (0: one built in memory)."""
    try:
        return os.stat(file).st_size
    except (OSError, ValueError):
        return 0


def _values(data: object) -> int:
    """How many values (lists, mappings, scalars) ``data`` holds."""
    count, stack = 0, [data]
    while stack:
        node = stack.pop()
        count += 1
        if isinstance(node, dict):
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
    return count


def _lookup(data: object, loc: Loc) -> object:
    node = data
    for part in loc:
        node = node[part]  # type: ignore[index]
    return node


def _describe(performer: str, kind: str, cue: object, context: str) -> str:
    """Short cue description for messages and transcripts: "rex: move body_z, pitch"."""
    what = getattr(cue, kind, None)
    if isinstance(what, dict):
        detail = ", ".join(map(str, what))
    elif isinstance(what, (str, int, float)) and not isinstance(what, bool):
        detail = str(what)
    else:
        detail = ""
    text = f"{performer}: {kind} {detail}".rstrip()
    return f"{text} ({context})" if context else text


def _given_in_music(cue: object, segments: int) -> tuple[float, str] | None:
    """A segment's length as the user wrote it, when in beats or bars (for messages)."""
    for unit in ("beats", "bars"):
        amount = getattr(cue, unit, None)
        if amount is not None:
            return float(amount) / segments, unit
    return None


def _initial_state(profile: Profile) -> dict[str, float]:
    state: dict[str, float] = {}
    for reg in profile.registers:
        if reg.limits is not None and reg.linear and reg.initial:
            state[reg.name] = reg.to_physical(reg.initial[0])
    return state


class _Emitter:
    """Turns one leaf cue into IR cues on its performer."""

    def __init__(
        self, res: _Resolver, perf: _Performer, kind: str, block: _Block, loc: Loc,
        origin: Origin,
    ) -> None:
        self.res, self.perf, self.kind, self.block, self.loc = res, perf, kind, block, loc
        self.origin = origin
        self.doc = block.doc
        self.profile = perf.profile

    def at(self, *parts: str | int) -> Loc:
        """A node inside this cue (a register's value, an LED's colour...)."""
        return (*self.loc, *parts)

    def error(self, message: str, *parts: str | int, key: bool = False) -> None:
        self.res.error(self.doc, (*self.loc, *parts), message, key=key)

    def refused(self) -> bool:
        """Report and return True when this cue's kind is not for the performer's robot family."""
        why = get_family(self.profile).refuse_cue(self.kind, self.profile)
        if why is not None:
            self.error(why, self.kind, key=True)
        return why is not None

    def needs_length(self, message: str, *parts: str | int, key: bool = False) -> None:
        """Report that this cue needs a duration, beats or bars, unless it had one that was
        malformed and left out (:mod:`~xgo_show.choreo.salvage`): that is reported already."""
        salvage = self.res.salvage
        if salvage is None or self.doc is not self.res.doc or self.loc not in salvage.lost_length:
            self.error(message, *parts, key=key)

    def add(
        self, cue: Cue, end: float, values: Mapping[str, Loc] | None = None,
        running: float = 0.0,
    ) -> None:
        """Emit ``cue``; ``values`` are the nodes each register's value came from."""
        if not self.within_samples(cue, end) or not self.within_cues():
            return
        self.perf.cues.append(cue)
        doc, label = self.doc, self.origin.cue
        locs = values or {}
        origins = _Located(locs, lambda loc: doc.origin(loc, label))
        paths = _Located(locs, doc.path)
        self.res.sources[id(cue)] = CueSource(
            self.perf.name, self.kind, doc, self.loc, self.origin, origins, paths, running, end)

    def within_cues(self) -> bool:
        """Count a cue made for the compiler; False, after one error here, past
        :data:`MAX_CUES` (a path of thousands of points is that many cues)."""
        res = self.res
        res.emitted += 1
        if res.emitted <= MAX_CUES:
            return True
        if not res.too_many:
            res.error(self.doc, self.loc, f"the show expands to more than {MAX_CUES:,} cues "
                      "for the robots by this one (each point of a path is a move of its "
                      "own); check the repeat counts and the paths' lengths")
            res.too_many = True
        return False

    def within_samples(self, cue: Cue, end: float) -> bool:
        """Count what ``cue`` costs the compiler (a move or a fade is sampled at the control
        rate over its length); False, after one error here, once the show needs more than
        :data:`MAX_SAMPLES` in all."""
        res = self.res
        if isinstance(cue, MotionCue):
            seconds = cue.duration if cue.duration is not None else end - cue.start
        elif isinstance(cue, FadeCue):
            seconds = cue.duration
        else:
            return True
        samples = max(seconds, 0.0) * res.show.settings.control_rate
        if isinstance(cue, FadeCue):  # a fade samples where its colour steps, at most
            samples = min(samples, _FADE_STEPS)
        res.samples += samples
        if res.samples <= MAX_SAMPLES:
            return True
        if not res.too_many:
            rate = res.show.settings.control_rate
            res.error(self.doc, self.loc, f"the show needs more than {MAX_SAMPLES:,} trajectory "
                      f"and fade samples by this cue ({rate:g} Hz over every second of "
                      "motion and fading, all performers together): lower "
                      "settings.control_rate or shorten the moves")
            res.too_many = True
        return False

    def cue(self, cue: object, start: float) -> float | None:
        given, length = self.res.cue_length(cue, start, self.doc, self.loc)
        if given and length is None:
            return None
        handler = getattr(self, f"on_{self.kind}")
        end: float | None = handler(cue, start, length)
        return end

    # -- kinds ----------------------------------------------------------------------------

    def on_action(self, cue: ActionCueModel, start: float, length: float | None) -> float | None:
        if not self.profile.actions:
            self.error(f"the {self.profile.title} has no preset actions", "action", key=True)
            return None
        try:
            act = self.profile.action(cue.action)
        except ProfileError:
            names = [a.name for a in self.profile.actions]
            hint = self.res.suggest(str(cue.action), names)
            valid = ", ".join(f"{a.name} ({a.id})" for a in self.profile.actions)
            self.error(f"the {self.profile.title} has no action {cue.action!r}{hint}; "
                       f"valid: {valid}", "action")
            return None
        if act.duration is None and length is None:
            self.needs_length(f"the documents give no duration for {self.profile.title} "
                              f"action {act.name!r}: give duration, beats or bars", "action")
            return None
        if act.duration is None and act.name not in self.res.show.settings.timed_by_hand:
            self.res.warning(self.doc, self.loc, f"action {act.name!r} lasts {length:.3g} s as "
                             "given by hand (the documents give no duration); once you have "
                             f"timed it on the robot, say so: settings: {{timed_by_hand: "
                             f"[{act.name}]}}")
        slot = length if length is not None else act.duration
        assert slot is not None
        running = act.duration if act.duration is not None else slot
        self.add(
            ActionCue(start, self.origin, act.id, act.name, slot, length is not None,
                      cue.interrupt),
            start + slot, {"action": self.at("action")}, running,
        )
        # The reset action restores the default posture (the planner starts moves from it too).
        self.perf.state.update(get_family(self.profile).after_action(self.profile, act.id))
        return start + slot

    def limits_for(self, names: Sequence[str], cue: MoveCueModel | None) -> dict[str, Limits]:
        out: dict[str, Limits] = {}
        regs = self.res.registers(self.profile)
        for name in names:
            reg = regs.get(name)
            base = reg.limits if reg is not None else None
            over = cue.limits.get(name) if cue is not None else None
            if over is None:
                if base is not None:
                    out[name] = base
                continue
            velocity = over.velocity or (base.velocity if base else None)
            acceleration = over.acceleration or (base.acceleration if base else None)
            jerk = over.jerk or (base.jerk if base else None)
            if velocity is None or acceleration is None or jerk is None:
                continue  # the checks report a register that cannot be moved
            out[name] = Limits(velocity, acceleration, jerk)
        return out

    def motion(
        self, points: Mapping[str, Sequence[float]], origins: Mapping[str, Sequence[Loc]],
        start: float, length: float | None, cue: MoveCueModel | None,
    ) -> float | None:
        counts = {len(v) for v in points.values() if len(v) > 1}
        if len(counts) > 1:
            self.error("every register in a multi-point move needs the same number of points "
                       f"(got {', '.join(f'{k}: {len(v)}' for k, v in points.items())})",
                       self.kind)
            return None
        segments = counts.pop() if counts else 1
        limits: dict[str, Limits] = {}
        overrides: dict[str, Limits] = {}
        if cue is not None and cue.limits:
            limits = self.limits_for(list(points), cue)
            for name in cue.limits:
                if name not in points:
                    self.error(f"limits given for {name!r}, which this move does not move",
                               "limits", name, key=True)
            overrides = {n: lim for n, lim in limits.items() if n in cue.limits}
        elif length is None:  # only an open-ended move needs them (its least duration)
            limits = self.limits_for(list(points), cue)
        given = _given_in_music(cue, segments)
        t = start
        for k in range(segments):
            targets: dict[str, float] = {}
            values: dict[str, Loc] = {}
            for name, seq in points.items():
                if len(seq) > 1 or k == 0:
                    targets[name] = seq[k] if len(seq) > 1 else seq[0]
                    values[name] = origins[name][k] if len(seq) > 1 else origins[name][0]
            if length is not None:
                seg = length / segments
                self.add(MotionCue(t, self.origin, targets, seg, overrides, cue is not None
                                   and cue.interrupt, (k + 1, segments), given),
                         t + seg, values)
                t += seg
            else:
                from xgo_show.compiler.trajectory import min_duration

                seg = min_duration(self.perf.state, targets, limits)
                self.add(MotionCue(t, self.origin, targets, None, overrides,
                                   cue is not None and cue.interrupt, (k + 1, segments)),
                         t + seg, values)
                t += seg
            self.perf.state.update(targets)
        return t

    def on_move(self, cue: MoveCueModel, start: float, length: float | None) -> float | None:
        points: dict[str, list[float]] = {}
        origins: dict[str, list[Loc]] = {}
        for name, value in cue.move.items():
            if isinstance(value, list):
                points[name] = list(value)
                origins[name] = [self.at("move", name, i) for i in range(len(value))]
            else:
                points[name] = [value]
                origins[name] = [self.at("move", name)]
        return self.motion(points, origins, start, length, cue)

    def on_gripper(self, cue: GripperCueModel, start: float, length: float | None) -> float | None:
        if self.refused():
            return None
        return self.motion({"gripper": [cue.gripper]}, {"gripper": [self.at("gripper")]},
                           start, length, None)

    def on_arm(self, cue: ArmCueModel, start: float, length: float | None) -> float | None:
        points: dict[str, list[float]] = {}
        origins: dict[str, list[Loc]] = {}
        for axis in ("x", "z"):
            value = getattr(cue.arm, axis)
            if value is not None:
                points[f"arm_{axis}"] = [value]
                origins[f"arm_{axis}"] = [self.at("arm", axis)]
        if not points:
            self.error("arm needs x and/or z (mm)", "arm")
            return None
        return self.motion(points, origins, start, length, None)

    def on_set(self, cue: SetCueModel, start: float, length: float | None) -> float | None:
        values: dict[str, object] = {}
        for name, value in cue.set.items():
            reg = next((r for r in self.profile.registers if r.name == name), None)
            if isinstance(value, bool) and reg is not None and reg.encoding is Encoding.ENUM:
                # true/false for an on/off choice (YAML 1.2 reads on/off as text).
                value = "on" if value else "off"
            if isinstance(value, float) and reg is not None and reg.encoding is Encoding.ENUM \
                    and value.is_integer():
                value = int(value)
            values[name] = value
            if isinstance(value, float) and reg is not None and reg.limits is not None:
                self.perf.state[name] = value
        end = start + (length or 0.0)
        self.add(SetCue(start, self.origin, values, cue.interrupt), end,
                 {n: self.at("set", n) for n in values})
        return end

    def on_walk(self, cue: WalkCueModel, start: float, length: float | None) -> float | None:
        if length is None:
            self.needs_length("walk needs duration, beats or bars, so that the robot stops "
                              "again", "walk", key=True)
            return None
        origins = {n: self.at("walk", n) for n in cue.walk}
        end = start + length
        self.add(SetCue(start, self.origin, dict(cue.walk), cue.interrupt), end, origins)
        stop = SetCue(end, self.origin, {n: 0.0 for n in cue.walk})
        self.add(stop, end, origins)
        return end

    def on_periodic(
        self, cue: PeriodicCueModel, start: float, length: float | None
    ) -> float | None:
        values = {f"periodic_{axis}": period for axis, period in cue.periodic.items()}
        origins = {f"periodic_{axis}": self.at("periodic", axis) for axis in cue.periodic}
        end = start + (length or 0.0)
        self.add(SetCue(start, self.origin, values, cue.interrupt), end, origins)
        if length is not None:
            self.add(SetCue(end, self.origin, {n: 0.0 for n in values}), end, origins)
        return end

    def on_led(self, cue: LedCueModel, start: float, length: float | None) -> float | None:
        leds = self.res.leds(self.profile)
        if not leds:
            self.error(f"the {self.profile.title} has no LEDs", "led", key=True)
            return None
        colors: dict[str, tuple[int, int, int]] = {}
        origins: dict[str, Loc] = {}
        ok = True
        for key, value in cue.led.items():
            targets = leds if key == "all" else [key]
            if key != "all" and key not in leds:
                self.error(f"no LED {key!r}{self.res.suggest(key, leds)}; "
                           f"LEDs: {', '.join(leds)} or all", "led", key, key=True)
                ok = False
                continue
            try:
                rgb = parse_color(value)
            except ValueError as exc:
                self.error(str(exc), "led", key)
                ok = False
                continue
            for name in targets:
                colors[name] = rgb
                origins[name] = self.at("led", key)
        if not ok:
            return None
        fade = 0.0
        if cue.fade is not None:
            fade = self.res.length(cue.fade, start, self.doc, (*self.loc, "fade")) or 0.0
        end = start + (length if length is not None else fade)
        if fade > 0:
            for name, rgb in colors.items():
                self.add(FadeCue(start, self.origin, name, rgb, fade, cue.interrupt), start + fade,
                         {name: origins[name]})
        else:
            self.add(SetCue(start, self.origin, colors, cue.interrupt), end, origins)
        return end

    def pose(
        self, positions: dict[int, int], origins: dict[int, Loc], start: float,
        length: float | None, interrupts: bool = False,
    ) -> float | None:
        if self.refused():
            return None
        if length is None:
            self.needs_length(f"{self.kind} needs duration, beats or bars (the xArm moves "
                              "every servo in a given time)", self.kind, key=True)
            return None
        if length > 65.535:
            self.error(f"an xArm move lasts at most 65.535 s, not {length:g} s", self.kind,
                       key=True)
            return None
        self.add(ArmCue(start, self.origin, positions, length, interrupts), start + length,
                 {str(k): v for k, v in origins.items()})
        return start + length

    def on_pose(self, cue: PoseCueModel, start: float, length: float | None) -> float | None:
        origins = {sid: self.at("pose", sid) for sid in cue.pose}
        return self.pose(dict(cue.pose), origins, start, length, cue.interrupt)

    def on_pose_deg(
        self, cue: PoseDegCueModel, start: float, length: float | None
    ) -> float | None:
        positions: dict[int, int] = {}
        for sid, degrees in cue.pose_deg.items():
            try:
                positions[sid] = degrees_to_position(degrees)
            except ValueRangeError as exc:
                self.error(str(exc), "pose_deg", sid)
        if not positions:
            return None
        # The servos whose angle converted are still checked (servo ids): every problem of
        # the cue in one run. An error was reported, so the show is not played anyway.
        origins = {sid: self.at("pose_deg", sid) for sid in positions}
        return self.pose(positions, origins, start, length, cue.interrupt)


def resolve_show(show: ShowFile, doc: Document, salvage: Salvage | None = None) -> Resolution:
    """Expand ``show`` (validated from ``doc``) into a :class:`ResolvedShow` with sources.

    ``salvage`` says ``show`` is what was left of a routine with structural errors: the
    resolver then keeps quiet about what those errors made unknowable.
    """
    return _Resolver(show, doc, salvage).run()

