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
from xgo_show.diagnostics import Diagnostic

__all__ = ["data_loc", "did_you_mean", "validate"]

M = TypeVar("M", bound=BaseModel)


def did_you_mean(word: str, choices: Sequence[str]) -> str:
    """``"; did you mean 'duration'?"`` or ``""``."""
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


def _message(err: Any, root: type[BaseModel]) -> str:
    msg = _plain_message(err, root)
    value = err.get("input")
    if isinstance(value, str) and _PARAM_LIKE.match(value) and err["type"] not in (
        "extra_forbidden", "missing",
    ):
        msg += _PARAM_HINT
    return msg


def _plain_message(err: Any, root: type[BaseModel]) -> str:
    kind = err["type"]
    raw_loc = err["loc"]
    if kind == "extra_forbidden":
        name = str(raw_loc[-1])
        allowed = _model_fields_at(root, raw_loc[:-1]) or []
        hint = did_you_mean(name, allowed)
        if not hint:
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
    msg = msg[:1].lower() + msg[1:]
    if kind == "string_pattern_mismatch":
        pattern = str((err.get("ctx") or {}).get("pattern", ""))
        what = _PATTERNS.get(pattern, "a value in the expected form")
        return f"should be {what}, not {_describe(err['input'])}"
    if kind in ("literal_error", "enum", "greater_than", "greater_than_equal", "less_than",
                "less_than_equal", "too_short", "too_long"):
        return f"{msg}, not {_describe(err['input'])}"
    if kind.endswith("_type") or kind.endswith("_parsing"):
        hint = ""
        if isinstance(err["input"], str) and _looks_numeric(err["input"]):
            hint = " (in quotes it is text: write the number without quotes)"
        return f"{msg}, not {_describe(err['input'])}{hint}"
    return msg


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
        kinds = []
        for e in group:
            match = _EXPECT.match(str(e["msg"]))
            kind = match[1] if match else str(e["msg"])
            if kind not in kinds:
                kinds.append(kind)
        merged = dict(err)
        merged["msg"] = "Input should be " + " or ".join(f"a {k}" for k in kinds)
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
        msg = _message(err, cls)
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
