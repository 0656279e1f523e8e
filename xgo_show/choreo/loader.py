"""Load a routine file: parse, validate, resolve, check. The public entry points.

:func:`load_show` gives the :class:`ResolvedShow` or raises :class:`ChoreographyError` with every
diagnostic found; :func:`validate_file` also runs the compiler and returns all diagnostics
(errors and warnings) without raising.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from xgo_show.choreo.checks import check_show
from xgo_show.choreo.model import CueList, ParamPartMapping, PartMapping, ShowFile
from xgo_show.choreo.resolve import resolve_show
from xgo_show.choreo.resolved import ResolvedShow
from xgo_show.choreo.section_rules import check_waits
from xgo_show.choreo.source import REFUSED, Document, read_yaml
from xgo_show.choreo.validation import validate
from xgo_show.diagnostics import Diagnostic, Origin, at_most_each_kind, once_each
from xgo_show.errors import ChoreographyError, CompileError, XgoShowError
from xgo_show.gcpause import paused_gc

__all__ = ["check_document", "check_file", "is_part", "load_show", "validate_file"]


def _sorted(diags: list[Diagnostic]) -> list[Diagnostic]:
    """Each problem once (a cue in a repeat reports once, with a count), in file order, errors
    first per line, and at most :data:`MAX_EACH_KIND` of each kind (then how many more)."""
    return at_most_each_kind(sorted(once_each(diags), key=lambda d: (
        d.origin.file if d.origin else "", d.origin.line if d.origin else 0,
        d.origin.column if d.origin else 0, d.severity != "error",
    )))


def check_file(path: str | Path) -> tuple[ResolvedShow | None, list[Diagnostic]]:
    """Parse, validate, resolve and check ``path``: the show (if no errors) and all findings."""
    try:
        with paused_gc():  # see gcpause: 10^5 nodes and cues, no cycle worth a collection
            return _check_file(path)
    except RecursionError:  # absurdly nested repeats/phrases/includes
        return None, [Diagnostic("error", "the routine is nested too deeply", Origin(
            str(path), 1, 1))]


def _check_file(path: str | Path) -> tuple[ResolvedShow | None, list[Diagnostic]]:
    doc, diags = read_yaml(Path(path), str(path))
    if not diags:
        return check_document(doc)
    if doc.data is None:  # unreadable, or not YAML at all: nothing more to check
        return None, _sorted(diags)
    # Values the reader refused (a number too large, a Python tag, a bad merge...) are built
    # as REFUSED, which no model accepts: the rest of the file is checked as well, and what
    # complains about a refused value again, at its place, was said already.
    said = {d.origin for d in diags}
    _, more = check_document(doc)
    again = repr(REFUSED)  # a complaint about a refused value inside the value checked
    return None, _sorted(diags + [d for d in more if d.origin not in said
                                  and again not in d.message])


def check_document(doc: Document) -> tuple[ResolvedShow | None, list[Diagnostic]]:
    """:func:`check_file` of a parsed routine: a file's, or one a behaviour builds in memory
    (a phrase or a setting played on its own), whose diagnostics point into ``doc``."""
    if is_part(doc.data):
        return None, _check_part(doc)
    if not isinstance(doc.data, dict):
        kind = type(doc.data).__name__
        diags = [Diagnostic("error", f"a routine is a mapping with show, performers and tracks, "
                            f"not {kind}", doc.origin(()))]
        return None, diags
    model, diags = validate(ShowFile, doc, doc.data)
    if model is None:
        return None, _sorted(diags + _check_remainder(doc, doc.data))
    res = resolve_show(model, doc)
    diags = res.diagnostics
    if res.show is not None:
        diags = diags + check_show(res) + check_waits(res)
    diags = _sorted(diags)
    if res.show is None or any(d.is_error for d in diags):
        return None, diags
    warnings = tuple(d for d in diags if not d.is_error)
    return dataclasses.replace(res.show, warnings=warnings), diags


def _check_remainder(doc: Document, data: dict[str, object]) -> list[Diagnostic]:
    """Resolve and check what is well formed in a routine with structural errors, so that
    one run lists every problem (a bad duration in one track hides nothing in another)."""
    from xgo_show.choreo.salvage import salvage_show  # for routines with errors alone

    salvage = salvage_show(data)
    if salvage is None:
        return []
    res = resolve_show(salvage.show, doc, salvage)
    return res.diagnostics + check_show(res) + check_waits(res)


def is_part(data: object) -> bool:
    """Whether parsed YAML is a part (an included file) rather than a routine."""
    if isinstance(data, list):
        return True
    return (
        isinstance(data, dict)
        and not {"show", "performers", "tracks"} & set(data)
        and bool({"phrases", "cues"} & set(data))
    )


_PART_NOTE = (
    "a part file (for include:), not a routine: only its structure was checked; the robot "
    "checks run when a routine includes it"
)


def _check_part(doc: Document) -> list[Diagnostic]:
    if isinstance(doc.data, list):
        _, diags = validate(CueList, doc, doc.data, (), wrap="cues")
    elif isinstance(doc.data, dict) and "params" in doc.data:
        part, diags = validate(ParamPartMapping, doc, doc.data)
        if part is not None:
            diags = _check_param_cues(doc, part)
    else:
        _, diags = validate(PartMapping, doc, doc.data)
    return _sorted([Diagnostic("warning", _PART_NOTE, doc.origin(())), *diags])


def _check_param_cues(doc: Document, part: ParamPartMapping) -> list[Diagnostic]:
    """Check a part's cues with its parameters' defaults put in. A parameter without a default
    has no value yet: what its uses need is checked when a routine includes the part."""
    from xgo_show.choreo.params import Argument, substitute  # for part files alone

    args = {
        name: None if default is None else Argument(default, doc, ("params", name))
        for name, default in part.params.items()
    }
    done = substitute(doc.data["cues"] if isinstance(doc.data, dict) else None, args,
                      at=("cues",), label="include", base=(), owner="this part")
    inst = doc.view(links=done.links)
    diags = [Diagnostic("error", message, inst.origin(loc, key=key), inst.path(loc))
             for loc, message, key in done.problems]
    _, found = validate(CueList, inst, done.data, ("cues",), wrap="cues")
    # Errors on a use of a valueless parameter, or on the value holding it (an 'at' mapping,
    # a list of targets), are not errors yet; the cue's own shape still is.
    open_ends = {inst.origin(hole[:n]) for hole in done.holes for n in range(3, len(hole) + 1)}
    open_ends |= {inst.origin(loc) for loc, _, _ in done.problems}  # reported already
    return diags + [d for d in found if d.origin not in open_ends]


def _summary(path: str | Path, diags: list[Diagnostic]) -> str:
    errors = [d for d in diags if d.is_error]
    count = sum(d.count for d in errors)
    first = errors[0].format() if errors else ""
    more = f" (and {count - 1} more)" if count > 1 else ""
    return f"{path}: {count} error(s): {first}{more}"


def load_show(path: str | Path) -> ResolvedShow:
    """Load the routine at ``path`` into a :class:`ResolvedShow`.

    Raises :class:`ChoreographyError` whose ``diagnostics`` list every problem found (not just
    the first); warnings are kept in ``ResolvedShow.warnings``.
    """
    show, diags = check_file(path)
    if show is None:
        errors = tuple(d for d in diags if d.is_error)
        if not errors:  # a well-formed part file
            errors = tuple(Diagnostic("error", d.message, d.origin) for d in diags)
        raise ChoreographyError(_summary(path, list(errors)), errors)
    return show


def validate_file(path: str | Path) -> list[Diagnostic]:
    """Every problem in the routine at ``path``, compiler findings included; never raises
    for a user mistake. Errors fail validation, warnings do not."""
    show, diags = check_file(path)
    if show is None:
        return diags
    try:
        from xgo_show.compiler import compile_diagnostics  # optional for loading
    except ImportError:
        return diags
    try:
        warnings = compile_diagnostics(show)
    except CompileError as exc:
        extra = list(exc.diagnostics)
        if not extra:
            extra = [Diagnostic("error", str(exc))]
        return _sorted(diags + extra)
    except XgoShowError as exc:  # any other user-facing failure of the compiler: one line
        return _sorted([*diags, Diagnostic("error", f"compiler: {exc}", Origin(str(path), 1, 1))])
    return _sorted(diags + list(warnings))
