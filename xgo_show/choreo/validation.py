"""Turn pydantic validation errors into diagnostics a choreographer can act on.

Each error gets the ``file:line:col`` of the offending node (via :class:`Document` marks), the
field path (``tracks.rex[3].move``) and a message saying what is wrong and what is allowed;
unknown fields get a "did you mean" suggestion.
"""

from __future__ import annotations

import difflib
import re
import types
import typing
from collections.abc import Sequence
from typing import Any, TypeVar

from pydantic import BaseModel, Tag, ValidationError

from xgo_show.choreo.model import CUE_KINDS
from xgo_show.choreo.source import Document, Loc
from xgo_show.choreo.unit import Unit
from xgo_show.diagnostics import Diagnostic
from xgo_show.profiles.model import limit_unit
from xgo_show.profiles.registry import register_units

__all__ = ["MAX_SUGGESTIONS", "Suggestions", "data_loc", "did_you_mean", "validate"]

M = TypeVar("M", bound=BaseModel)


#: Fuzzy searches one check may make. Each costs about a millisecond over a robot's fifty
#: registers; a generated file with thousands of unknown names would spend seconds on hints
#: nobody reads (only the first MAX_EACH_KIND of a kind are listed).
MAX_SUGGESTIONS = 100
#: Choices searched at most: a longer list (thousands of phrases) gets no suggestion.
_MAX_CHOICES = 500


class Suggestions:
    """:func:`did_you_mean` for one check of one file, up to :data:`MAX_SUGGESTIONS` times;
    then ``""``, so that the cost of a file follows its errors only up to a bound."""

    def __init__(self, limit: int = MAX_SUGGESTIONS) -> None:
        self.left = limit

    def __call__(self, word: str, choices: Sequence[str]) -> str:
        if self.left <= 0:
            return ""
        self.left -= 1
        return did_you_mean(word, choices)


def did_you_mean(word: str, choices: Sequence[str]) -> str:
    """``"; did you mean 'duration'?"`` or ``""``."""
    if len(choices) > _MAX_CHOICES:
        return ""
    close = difflib.get_close_matches(word, list(choices), n=2, cutoff=0.6)
    if not close:
        return ""
    return "; did you mean " + " or ".join(repr(c) for c in close) + "?"


def data_loc(data: object, loc: Sequence[str | int]) -> Loc:
    """The part of a pydantic ``loc`` that addresses real data (union tags are dropped)."""
    out: list[str | int] = []
    node = data
    for part in loc:
        in_list = isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node)
        if (isinstance(node, dict) and part in node) or in_list:
            out.append(part)
            node = node[part]  # type: ignore[index]
        elif isinstance(node, dict) and str(part).isdigit() and int(part) in node:
            out.append(int(part))
            node = node[int(part)]
        elif part == loc[-1] and isinstance(node, dict) and not _is_tag(part):
            out.append(part)  # a missing or unknown key: keep it for the message
            break
    return tuple(out)


def _is_tag(part: str | int) -> bool:
    return isinstance(part, str) and (
        part.endswith(("-cue", "-kind")) or part in {"constant", "map", "file"}
    )


def _unwrap(tp: Any) -> tuple[Any, list[Any]]:
    """``Annotated[X, ...]`` and ``X | None`` -> X (and the annotations)."""
    meta: list[Any] = []
    while True:
        if typing.get_origin(tp) is typing.Annotated:
            args = typing.get_args(tp)
            tp, meta = args[0], meta + list(args[1:])
            continue
        if typing.get_origin(tp) in (typing.Union, types.UnionType):
            members = [m for m in typing.get_args(tp) if m is not type(None)]
            if len(members) == 1:  # Optional: pydantic's loc has no step for it
                tp = members[0]
                continue
        return tp, meta


def _model_fields_at(root: type[BaseModel], loc: Sequence[str | int]) -> list[str] | None:
    """Field names (aliases) of the model that ``loc`` (a pydantic loc) lands in."""
    tp: Any = root
    for part in loc:
        tp, _ = _unwrap(tp)
        origin = typing.get_origin(tp)
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            found = None
            for name, info in tp.model_fields.items():
                if part in (name, info.alias):
                    found = info.annotation
                    break
            if found is None:
                return None
            tp = found
        elif origin is dict:
            tp = typing.get_args(tp)[1]
        elif origin is list:
            tp = typing.get_args(tp)[0]
        elif origin in (typing.Union, types.UnionType):
            chosen = None
            for member in typing.get_args(tp):
                inner, meta = _unwrap(member)
                if any(isinstance(m, Tag) and m.tag == part for m in meta):
                    chosen = inner
                    break
            if chosen is None:
                return None
            tp = chosen
        else:
            return None
    tp, _ = _unwrap(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [info.alias or name for name, info in tp.model_fields.items()]
    return None


def _describe(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


_PARAM_LIKE = re.compile(r"^-?\$[A-Za-z_][A-Za-z0-9_]*$")
_PARAM_HINT = (
    " (parameters ($name) work in the cues of a phrase, or of a part file with params:)"
)


def _message(err: Any, root: type[BaseModel], where: Loc = ()) -> str:
    msg = _plain_message(err, root, where)
    value = err.get("input")
    if isinstance(value, str) and _PARAM_LIKE.match(value) and err["type"] not in (
        "extra_forbidden", "missing",
    ):
        msg += _PARAM_HINT
    return msg


def _plain_message(err: Any, root: type[BaseModel], where: Loc) -> str:
    """The error in our words: what was written, what is allowed (in the field's unit)."""
    kind = err["type"]
    raw_loc = err["loc"]
    if kind == "extra_forbidden":
        name = str(raw_loc[-1])
        allowed = _model_fields_at(root, raw_loc[:-1]) or []
        hint = did_you_mean(name, allowed)
        if not hint and "after" in allowed:  # in a cue: perhaps a misspelt kind
            kinds = did_you_mean(name, CUE_KINDS)
            hint = kinds.replace("did you mean", "a cue kind is one key; did you mean", 1)
        listing = f" (allowed: {', '.join(allowed)})" if allowed else ""
        return f"unknown field {name!r}{hint}{listing}"
    if kind == "missing":
        return f"missing required field {raw_loc[-1]!r}"
    if kind == "cue_kind":
        value = err["input"]
        if not isinstance(value, dict):
            return f"a cue is a mapping such as {{action: stand_up}}, not {_describe(value)}"
        present = [k for k in CUE_KINDS if k in value]
        if len(present) > 1:
            return (
                f"one cue, one kind: this cue has {', '.join(present)}; "
                "split it into separate cues (use 'at' to start them together)"
            )
        unknown = [str(k) for k in value if k not in _COMMON_FIELDS]
        hints = "".join(did_you_mean(k, CUE_KINDS) for k in unknown[:1])
        return f"a cue needs one kind key: {', '.join(CUE_KINDS)}{hints}"
    msg = str(err["msg"])
    if kind.startswith(("position", "length", "timing")):
        return msg
    if kind == "string_pattern_mismatch":
        pattern = str((err.get("ctx") or {}).get("pattern", ""))
        what = _PATTERNS.get(pattern, "a value in the expected form")
        return f"should be {what}, not {_describe(err['input'])}"
    if kind in _RANGE:
        return _range_message(err, root, where)
    if kind in ("too_short", "too_long", "string_too_short", "string_too_long"):
        return _length_message(err)
    if kind in ("literal_error", "enum"):
        expected = str((err.get("ctx") or {}).get("expected", "")) or _expected(err)
        several = "one of " if " or " in expected else ""
        return f"should be {several}{expected}, not {_describe(err['input'])}"
    if kind in _EXPECTED or kind == "union_type" or kind.endswith(_TYPE_KINDS):
        hint = ""
        if isinstance(err["input"], str) and _looks_numeric(err["input"]):
            hint = " (in quotes it is text: write the number without quotes)"
        return f"should be {_expected(err)}, not {_describe(err['input'])}{hint}"
    for prefix in ("Value error, ", "Assertion failed, "):  # a validator's own message
        if msg.startswith(prefix):
            return msg[len(prefix):]
    return _reword(msg)


def _reword(msg: str) -> str:
    """Whatever else pydantic says, without its "Input should be a valid ..." phrasing."""
    match = _EXPECT.match(msg)
    if match:
        return f"should be {match[1]}"
    return msg[:1].lower() + msg[1:]


_NUMBER = re.compile(r"^\s*[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?\s*$")
# What the model's string patterns mean, in words (a regex is not a message).
_PATTERNS = {
    r"^[A-Za-z_][A-Za-z0-9_-]*$": (
        "a name of letters, digits, '_' and '-', starting with a letter or '_'"
    ),
}


def _looks_numeric(text: str) -> bool:
    """Whether ``text`` would be a number unquoted (YAML 1.2: ``1e3``, ``.5``, ``-2``)."""
    return _NUMBER.match(text) is not None


_COMMON_FIELDS = frozenset(
    {"at", "after", "duration", "beats", "bars", "interrupt", "limits", "fade", "with", "cues"}
)


_EXPECT = re.compile(r"^Input should be (?:a valid |an? )?(.+)$")


# -- pydantic's complaints in our words ---------------------------------------------------------

# What a value should be, by pydantic's error type.
_EXPECTED = {
    "int_type": "a whole number", "int_parsing": "a whole number",
    "int_from_float": "a whole number", "float_type": "a number", "float_parsing": "a number",
    "bool_type": "true or false", "bool_parsing": "true or false", "string_type": "text",
    "dict_type": "a mapping (name: value)", "model_type": "a mapping (name: value)",
    "model_attributes_type": "a mapping (name: value)", "list_type": "a list",
    "finite_number": "a finite number", "none_required": "nothing (null)",
}
# The unit of a field by its name, when its type carries no Unit.
_FIELD_UNITS = {
    "duration": "s", "after": "s", "at": "s", "fade": "s", "timeout": "s", "offset": "s",
    "end": "s", "beats": "beats", "bars": "bars", "control_rate": "Hz", "gap_ms": "ms",
    "battery_floor": "%", "bpm": "bpm", "beats_per_bar": "beats",
}
_LIMIT_UNITS = {"velocity": "per second", "acceleration": "per second²", "jerk": "per second³"}
_LOW = ("greater_than", "greater_than_equal")
_RANGE = (*_LOW, "less_than", "less_than_equal")


def _number(value: object) -> str:
    """``1e-12``, ``1e7``, ``0.001``, ``-1``: as short as a person writes it."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return _describe(value)
    text = f"{value:g}"
    return re.sub(r"e([+-])0*(\d)", lambda m: "e" + m[1].replace("+", "") + m[2], text)


def _field_meta(root: type[BaseModel], loc: Sequence[str | int]) -> list[Any]:
    """Every annotation met on the way to the field at pydantic ``loc`` (empty if lost)."""
    tp: Any = root
    meta: list[Any] = []
    for part in loc:
        tp, found = _unwrap(tp)
        meta = found
        origin = typing.get_origin(tp)
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            info = next((i for n, i in tp.model_fields.items() if part in (n, i.alias)), None)
            if info is None:
                return []
            tp, meta = info.annotation, list(info.metadata)
        elif origin is dict:
            tp = typing.get_args(tp)[1]
        elif origin is list:
            tp = typing.get_args(tp)[0]
        elif origin in (typing.Union, types.UnionType):
            # A member by its tag, or (untagged) by its type's name: pydantic's "int", "list[...]"
            members = [_unwrap(m) for m in typing.get_args(tp)]
            chosen = next(((inner, m) for inner, m in members
                           if any(isinstance(x, Tag) and x.tag == part for x in m)
                           or _type_name(inner) == str(part).split("[")[0].removeprefix(
                               "constrained-")), None)
            if chosen is None:
                return []
            tp, meta = chosen[0], meta + chosen[1]
        else:
            return []
    tp, found = _unwrap(tp)
    return meta + found


def _type_name(tp: Any) -> str:
    origin = typing.get_origin(tp)
    return str(getattr(origin or tp, "__name__", ""))


def _flat(meta: list[Any]) -> list[Any]:
    out: list[Any] = []
    for m in meta:
        out.extend(getattr(m, "metadata", None) or [m])  # a FieldInfo holds its constraints
    return out


def _unit(meta: list[Any], data_path: Loc) -> str:
    for m in meta:
        if isinstance(m, Unit):
            return m.symbol
    names = [p for p in data_path if isinstance(p, str)]
    if len(names) >= 2 and names[-1] in _LIMIT_UNITS and "limits" in names:
        # The register's own unit (the model is not known yet: the units it has on any).
        units = [limit_unit(u, names[-1]) for u in register_units(names[-2])]
        return " or ".join(units) if units else f"{names[-2]}'s unit {_LIMIT_UNITS[names[-1]]}"
    return _FIELD_UNITS.get(names[-1], "") if names else ""


def _range_message(err: Any, root: type[BaseModel], data_path: Loc) -> str:
    """``0 ms is too small: give 1 to 1000 ms``: the value, which way it is off, the range."""
    meta = _flat(_field_meta(root, err["loc"]))
    bounds = dict((err.get("ctx") or {}).items())
    for m in meta:
        for name in ("gt", "ge", "lt", "le"):
            if getattr(m, name, None) is not None:
                bounds.setdefault(name, getattr(m, name))
    unit = _unit(meta, data_path)
    written = _number(err["input"])
    sep = "" if unit in ("", "%") else " "
    per = " or " in unit or "unit" in unit
    if per:  # "give 0.001 to 1e7 (mm/step/s or m/s²)": the unit depends on the model
        unit_after, unit_tail = "", f" ({unit})"
    else:
        unit_after, unit_tail = f"{sep}{unit}" if unit else "", ""
    lo = (f"{_number(bounds['ge'])}", True) if "ge" in bounds else (
        (f"{_number(bounds['gt'])}", False) if "gt" in bounds else None)
    hi = (f"{_number(bounds['le'])}", True) if "le" in bounds else (
        (f"{_number(bounds['lt'])}", False) if "lt" in bounds else None)
    if lo and hi and lo[1] and hi[1]:
        allowed = f"{lo[0]} to {hi[0]}{unit_after}"
    elif lo and hi:
        low = f"{lo[0]}" if lo[1] else f"more than {lo[0]}"
        high = f"at most {hi[0]}" if hi[1] else f"less than {hi[0]}"
        allowed = f"{low} and {high}{unit_after}"
    elif lo:
        allowed = f"{lo[0]}{unit_after} or more" if lo[1] else f"more than {lo[0]}{unit_after}"
    elif hi:
        allowed = f"at most {hi[0]}{unit_after}" if hi[1] else f"less than {hi[0]}{unit_after}"
    else:
        allowed = "a value in range"
    which = "too small" if err["type"] in _LOW else "too large"
    return f"{written}{unit_after} is {which}: give {allowed}{unit_tail}"


def _length_message(err: Any) -> str:
    """An empty list, mapping or text (or one too long), said as such."""
    ctx = err.get("ctx") or {}
    value = err["input"]
    item = ("character" if isinstance(value, str) else
            "entry (name: value)" if isinstance(value, dict) else "item")
    items = "characters" if item == "character" else (
        "entries" if isinstance(value, dict) else "items")
    if str(err["type"]).endswith("too_short"):
        need = int(ctx.get("min_length", 1))
        what = (f"{_describe(value)} is empty" if not value
                else f"{_describe(value)} has {len(value)} {items if len(value) != 1 else item}")
        return f"{what}: give at least {need} {item if need == 1 else items}"
    most = int(ctx.get("max_length", 0))
    return f"{_describe(value)} has {len(value)} {items}: give at most {most}"


def _expected(err: Any) -> str:
    """What the value should have been, in words ("a whole number", "true or false")."""
    kind = str(err["type"])
    if kind == "union_type":
        return str(err["ctx"]["expected"])
    if kind in _EXPECTED:
        return _EXPECTED[kind]
    match = _EXPECT.match(str(err["msg"]))
    return (match[1] if match else str(err["msg"])).split(",")[0]


_TYPE_KINDS = ("_type", "_parsing")  # "not a string", "unable to parse as an integer"


def _drop_wrong_branches(payload: object, errors: list[Any]) -> list[Any]:
    """A value of one of a union's types reports only that branch's complaint: ``99999`` for
    ``str | int <= 255`` is too large, not "not a string"; ``.nan`` for ``number | list`` is not
    finite, not "not a list". The type errors of the other branches are noise."""
    specific: dict[Loc, set[tuple[object, ...]]] = {}
    for err in errors:
        if not str(err["type"]).endswith(_TYPE_KINDS):
            specific.setdefault(data_loc(payload, err["loc"]), set()).add(tuple(err["loc"]))
    out = []
    for err in errors:
        if str(err["type"]).endswith(_TYPE_KINDS):
            here = data_loc(payload, err["loc"])
            # A complaint at or below this value from another branch: that branch took the
            # value's type (a list of numbers with a nan in it is a list, not a bad number).
            if any(loc[:len(here)] == here and raws - {tuple(err["loc"])}
                   for loc, raws in specific.items()):
                continue
        out.append(err)
    return out


def _merge_union_errors(payload: object, errors: list[Any]) -> list[Any]:
    """One message for a value that fits none of a union's types ("a number or a list")."""
    errors = _drop_wrong_branches(payload, errors)
    groups: dict[Loc, list[Any]] = {}
    for err in errors:
        if str(err["type"]).endswith("_type"):
            groups.setdefault(data_loc(payload, err["loc"]), []).append(err)
    out: list[Any] = []
    done: set[Loc] = set()
    for err in errors:
        loc = data_loc(payload, err["loc"])
        group = groups.get(loc, [])
        if len(group) < 2 or err not in group:
            out.append(err)
            continue
        if loc in done:
            continue
        done.add(loc)
        kinds = list(dict.fromkeys(_expected(e) for e in group))
        merged = dict(err)
        merged["type"] = "union_type"
        merged["ctx"] = {"expected": ", ".join(kinds[:-1]) + " or " + kinds[-1]}
        out.append(merged)
    return out


def validate(
    cls: type[M], doc: Document, data: object, base: Loc = (), *, wrap: str | None = None
) -> tuple[M | None, list[Diagnostic]]:
    """Validate ``data`` (found at ``base`` in ``doc``) as ``cls``; every error is reported.

    ``wrap`` validates ``{wrap: data}`` instead (a bare list as a one-field model); locations
    still point into ``data``.
    """
    payload = {wrap: data} if wrap is not None else data
    try:
        return cls.model_validate(payload), []
    except ValidationError as exc:
        errors = exc.errors(include_url=False)
    diags: list[Diagnostic] = []
    seen: set[tuple[Loc, str]] = set()
    errors = _merge_union_errors(payload, errors)
    for err in errors:
        loc = data_loc(payload, err["loc"])
        if wrap is not None:
            loc = loc[1:]
        msg = _message(err, cls, loc)
        if loc and loc[-1] == "[key]":  # a mapping key that is not allowed: the key's place
            loc = loc[:-1]
        full = (*base, *loc)
        if (full, msg) in seen:
            continue
        seen.add((full, msg))
        # An unknown field, or a mapping key that is not allowed: point at the key itself.
        key = err["type"] == "extra_forbidden" or "[key]" in err["loc"]
        origin = doc.origin(full, key=key)
        diags.append(Diagnostic("error", msg, origin, doc.path(full)))
    return None, diags
