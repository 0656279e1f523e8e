"""Read a YAML file into plain data plus the line:column of every node.

PyYAML's ``safe_load`` forgets where values came from and silently keeps the last of two equal
keys. We compose the node tree with the safe loader instead and build the data ourselves, so
that every error (from pydantic or from our own checks) can name the exact ``file:line:col``,
and a duplicate key is an error. Only the safe YAML subset is understood (no Python tags).
"""

from __future__ import annotations

import functools
import math
import operator
import re
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml
from yaml.constructor import SafeConstructor
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from xgo_show.choreo.yaml_hints import colour_comment_hints
from xgo_show.diagnostics import Diagnostic, Origin
from xgo_show.errors import FileAccessError
from xgo_show.files import MAX_ROUTINE_BYTES, read_text_file
from xgo_show.text import control_characters, printable

__all__ = [
    "MAX_NODES", "REFUSED", "Document", "Link", "Loc", "Refused", "format_path", "parse_yaml",
    "read_text", "read_yaml",
]

Loc = tuple[str | int, ...]

# Values a file may expand to, aliases counted at each use. A ten-minute show of dense cues is
# some 10^5; a "billion laughs" file (anchors of anchors) is 10^9 and would eat the memory.
MAX_NODES = 1_000_000

_MERGE_TAG = "tag:yaml.org,2002:merge"
_INT_TAG = "tag:yaml.org,2002:int"
_FLOAT_TAG = "tag:yaml.org,2002:float"
_STR_TAG = "tag:yaml.org,2002:str"
_SEQ_TAG = "tag:yaml.org,2002:seq"
_BOOL_TAG = "tag:yaml.org,2002:bool"

#: Deepest nesting of lists and mappings: a routine with ten nested repeats is some 25 levels.
MAX_DEPTH = 64
#: Largest whole number a routine may hold (a float holds every integer up to 2^53 exactly).
MAX_INT = 2**53
#: Numbers are read as YAML 1.2 (core schema), not PyYAML's YAML 1.1: ``1e3`` is a number,
#: ``0o17``/``0x1F`` are octal/hex, and ``1_000``, ``1:30`` or ``2024-01-01`` stay text. A
#: leading zero (``0500``) is refused: YAML 1.1 tools read it as octal (320), 1.2 as 500.
_INT_12 = re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$")
_FLOAT_12 = re.compile(
    r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
    r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"
)

#: Booleans as YAML 1.2 too: only true and false. YAML 1.1 also reads yes/no/on/off, so that
#: ``gait: no`` became false and then "off", and ``imu_mode: off`` a boolean: as text they
#: say what was written (``off`` is a choice and a colour; ``yes`` for a true/false field is
#: an error that names it).
_BOOL_12 = re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$")

# A float PyYAML reads as float() of the text (no .inf, no sign dance): see _Builder.scalar.
_DECIMAL = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?\Z")


class _Loader(yaml.SafeLoader):
    """The safe loader with YAML 1.2 numbers (see :data:`_INT_12`) and booleans (see
    :data:`_BOOL_12`); nulls as before."""


_Loader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers
            if tag not in (_INT_TAG, _FLOAT_TAG, _BOOL_TAG, "tag:yaml.org,2002:timestamp")]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(_INT_TAG, _INT_12, list("-+0123456789"))
_Loader.add_implicit_resolver(_FLOAT_TAG, _FLOAT_12, list("-+0123456789."))
_Loader.add_implicit_resolver(_BOOL_TAG, _BOOL_12, list("tTfF"))


class _Resolver(yaml.resolver.Resolver):
    """:class:`_Loader`'s tags alone (they depend on its class attributes only)."""

    yaml_implicit_resolvers = _Loader.yaml_implicit_resolvers


_RESOLVER = _Resolver()


@dataclass(frozen=True)
class Link:
    """A node of a block whose value was written elsewhere: a parameter's value, at its use.

    ``doc``/``loc`` is where the value was written (a call's ``with:`` entry or the parameter's
    default), ``label`` names the block it was passed into (``phrase nod``, ``include
    parts/a.yaml``) and ``base`` is that block's own place, so paths inside it read relative.
    """

    doc: Document
    loc: Loc
    label: str
    base: Loc


@dataclass
class Document:
    """A parsed YAML file: its data and where each value (and each mapping key) starts.

    A *view* of a document (:meth:`view`) shares its data and marks but knows how it was
    reached: ``via`` is the field path of the include that played it, and ``links`` map the
    nodes filled in from parameters to where their values were written. Diagnostics then point
    at the value's own ``file:line:col`` and show the whole chain in the field path.
    """

    file: str
    data: object
    marks: dict[Loc, tuple[int, int]] = field(default_factory=dict)  # value node, 1-based
    key_marks: dict[Loc, tuple[int, int]] = field(default_factory=dict)  # key of that value
    via: str = ""  # "tracks.rex[3] -> include parts/a.yaml": how this view was reached
    links: dict[Loc, Link] = field(default_factory=dict)

    def view(self, *, via: str | None = None, links: dict[Loc, Link] | None = None) -> Document:
        """The same file reached another way (an include, a parameterised block)."""
        return replace(self, via=self.via if via is None else via,
                       links=self.links if links is None else links)

    def linked(self, loc: Sequence[str | int]) -> tuple[Link, Loc] | None:
        """The parameter link ``loc`` lies in (and the rest of ``loc`` inside the value)."""
        if not self.links:
            return None
        path = tuple(loc)
        for n in range(len(path), -1, -1):
            link = self.links.get(path[:n])
            if link is not None:
                return link, path[n:]
        return None

    def origin(self, loc: Sequence[str | int], cue: str = "", *, key: bool = False) -> Origin:
        """Where ``loc`` is in the file; the nearest enclosing node if ``loc`` is not there.

        ``key=True`` points at the mapping key rather than its value (for unknown fields). A
        node filled in from a parameter is where the parameter's value was written.
        """
        found = self.linked(loc)
        if found is not None and (found[1] or not key):  # the key itself is this block's
            link, rest = found
            return link.doc.origin((*link.loc, *rest), cue, key=key)
        path = tuple(loc)
        while path:
            table = self.key_marks if key else self.marks
            if path in table:
                line, col = table[path]
                return Origin(self.file, line, col, cue)
            path = path[:-1]
            key = False
        line, col = self.marks.get((), (1, 1))
        return Origin(self.file, line, col, cue)

    def path(self, loc: Sequence[str | int]) -> str:
        """The field path of ``loc`` for messages, with the includes and parameters that led
        there: ``tracks.rex[1].with.depth -> phrase nod cues[0].move.pitch``."""
        found = self.linked(loc)
        if found is not None:
            link, rest = found
            inner = tuple(loc)
            if inner[:len(link.base)] == link.base:
                inner = inner[len(link.base):]
            return f"{link.doc.path((*link.loc, *rest))} -> {link.label} {format_path(inner)}"
        here = format_path(loc)
        return f"{self.via} {here}" if self.via else here


def format_path(loc: Sequence[str | int]) -> str:
    """``("tracks", "rex", 3, "move")`` -> ``tracks.rex[3].move``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


class Refused:
    """What a value the reader refused (reported at its place: a number too large, a leading
    zero, a control character, a Python tag...) is built as. No model accepts it, so the rest
    of the file is still checked (one error does not hide the others) and whatever complains
    about it again complains at the same place, which the loader drops as said already."""

    def __repr__(self) -> str:
        return "<refused value>"

    def __deepcopy__(self, memo: dict[int, object]) -> Refused:
        return self


#: The one :class:`Refused` value.
REFUSED = Refused()


class _Builder:
    def __init__(self, doc: Document, *, aliases: bool = True) -> None:
        self.doc = doc
        self.marks = doc.marks
        self.key_marks = doc.key_marks
        self.constructor = SafeConstructor()
        self.errors: list[Diagnostic] = []
        # Without aliases no node is reached twice: no recursive alias to look out for.
        self._active: set[int] | None = set() if aliases else None
        # What each (tag, text) of a scalar read as, when it read without a problem: a
        # routine repeats its keys and many of its numbers, each read once (a problem is
        # reported at every place it occurs, so only values are kept).
        self._plain: dict[tuple[str, str], object] = {}
        # A node left unbuilt (a duplicate key's value, a key that is no name, a merge):
        # the values built are then not all the nodes, and the depth of those is unknown.
        self.inexact = False
        # Nesting is bounded here only without aliases (with them, the walk bounded it first,
        # along the first path to each node).
        self._deepest_loc = MAX_DEPTH - 1 if not aliases else math.inf

    def error(self, node: Node, loc: Loc, message: str) -> None:
        mark = node.start_mark
        origin = Origin(self.doc.file, mark.line + 1, mark.column + 1)
        self.errors.append(Diagnostic("error", message, origin, format_path(loc)))

    def build(self, node: Node, loc: Loc) -> object:
        mark = node.start_mark
        self.marks[loc] = (mark.line + 1, mark.column + 1)
        if isinstance(node, ScalarNode):
            return self.scalar(node, loc)
        active = self._active
        if active is None:  # no aliases: no node is inside itself
            return self.collection(node, loc)
        if id(node) in active:  # an alias that contains itself
            self.error(node, loc, "recursive YAML alias")
            return REFUSED
        active.add(id(node))
        try:
            return self.collection(node, loc)
        finally:
            active.discard(id(node))

    def collection(self, node: Node, loc: Loc) -> object:
        if len(loc) >= self._deepest_loc and node.value:  # its items would be past MAX_DEPTH
            self.inexact = True  # the walk then finds where, and nothing built is kept
            return REFUSED
        if isinstance(node, SequenceNode):
            if node.tag != _SEQ_TAG:
                self.error(node, loc, f"unsupported YAML tag {node.tag}")
            build = self.build
            return [build(item, (*loc, i)) for i, item in enumerate(node.value)]
        if isinstance(node, MappingNode):
            return self.build_mapping(node, loc)
        self.error(node, loc, f"unsupported YAML node {node.tag}")
        return REFUSED

    def build_mapping(self, node: MappingNode, loc: Loc) -> dict[str | int, object]:
        if node.tag not in ("tag:yaml.org,2002:map",):
            self.error(node, loc, f"unsupported YAML tag {node.tag}")
        # "<<: *anchor" merges first: building them records their places, and the explicit
        # keys, built after, put theirs over them (explicit keys win, as in YAML 1.1), so a
        # problem in a key written here is reported here, not in the anchor.
        merged: dict[str | int, object] = {}
        for key_node, value_node in node.value:
            if key_node.tag == _MERGE_TAG:
                self.inexact = True
                sources = value_node.value if isinstance(value_node, SequenceNode) else [
                    value_node]
                for src in sources:
                    if not isinstance(src, MappingNode):
                        self.error(src, loc, "'<<' merges mappings only")
                        continue
                    for name, value in self.build_mapping(src, loc).items():
                        merged.setdefault(name, value)
        out: dict[str | int, object] = {}
        marks, key_marks, build, plain = self.marks, self.key_marks, self.build, self._plain
        for key_node, value_node in node.value:
            tag = key_node.tag
            if tag == _MERGE_TAG:
                continue
            if not isinstance(key_node, ScalarNode):
                self.error(key_node, loc, "a mapping key must be a plain value, not a list or map")
                self.inexact = True
                continue
            key = plain.get((tag, key_node.value))  # a key read before
            if key.__class__ is not str and key.__class__ is not int:  # or not a name
                key = self.build_key(key_node, loc)
                if key is None:
                    self.inexact = True
                    continue
            here: Loc = (*loc, key)
            if key in out:
                first = key_marks.get(here)
                where = f" (first at line {first[0]})" if first else ""
                self.error(key_node, here, f"duplicate key {key!r}{where}")
                self.inexact = True
                continue
            mark = key_node.start_mark
            key_marks[here] = (mark.line + 1, mark.column + 1)
            if value_node.__class__ is ScalarNode:  # build() of a value read before, inline
                mark = value_node.start_mark
                marks[here] = (mark.line + 1, mark.column + 1)
                value = plain.get((value_node.tag, value_node.value), REFUSED)
                out[key] = value if value is not REFUSED else self.scalar(value_node, here)
            else:
                out[key] = build(value_node, here)
        for name, value in merged.items():
            out.setdefault(name, value)
        return out

    def scalar(self, node: ScalarNode, loc: Loc) -> object:
        """A plain value: numbers as YAML 1.2 (and within range), text without control
        characters; an error (and :data:`REFUSED`) otherwise."""
        tag = node.tag
        text = node.value
        value: object = self._plain.get((tag, text), REFUSED)
        if value is not REFUSED:
            return value
        value = self.read_scalar(node, loc)
        if value is not REFUSED:
            self._plain[tag, text] = value
        return value

    def read_scalar(self, node: ScalarNode, loc: Loc) -> object:
        tag = node.tag
        if tag == _INT_TAG:
            return self.integer(node, loc)
        value: object
        # Text and plain decimals, nearly every value of a routine, are what PyYAML's
        # constructor makes of them (the text itself; the sign times float() of the rest),
        # without its dispatch per node: a third of loading a long routine.
        if tag == _STR_TAG:
            value = node.value
        elif tag == _FLOAT_TAG and _DECIMAL.match(node.value):
            value = float(node.value)
        else:
            value = self.construct(node, loc)
            if value is None or value is REFUSED:
                return value
        if isinstance(value, float) and not math.isfinite(value):
            what = "infinite" if math.isinf(value) else "not a number"
            self.error(node, loc, f"{node.value} is {what}: give a finite number")
            return REFUSED
        if isinstance(value, float) and abs(value) > MAX_INT:
            self.error(node, loc, f"{node.value} is too large (at most about 9e15)")
            return REFUSED
        if isinstance(value, str):
            bad = control_characters(value)
            if bad is not None:
                self.error(node, loc, f"the text holds the control character {bad}: "
                           "write plain text")
                return REFUSED
        return value

    def construct(self, node: ScalarNode, loc: Loc) -> object:
        """Any other scalar through PyYAML's constructor; :data:`REFUSED` (reported) when it
        fails or makes something a routine does not hold."""
        try:
            value = self.constructor.construct_object(node, deep=True)
        except yaml.YAMLError as exc:
            problem = _problem(exc)
            if "could not determine a constructor" in problem:  # !!python/..., !custom
                tag = node.tag.replace("tag:yaml.org,2002:", "!!", 1)
                problem = (f"the tag {printable(tag)} is not allowed: a routine holds "
                           "plain values (numbers, text, true/false, lists and mappings)")
            self.error(node, loc, problem)
            return REFUSED
        except ValueError:  # an explicit tag on a value it does not fit (!!float abc)
            self.error(node, loc, f"{printable(node.value)!r} is not a {node.tag.rsplit(':')[-1]}")
            return REFUSED
        if value is not None and not isinstance(value, (str, int, float)):  # !!binary, ...
            self.error(node, loc, f"unsupported YAML tag {printable(node.tag)}")
            return REFUSED
        return value

    def integer(self, node: ScalarNode, loc: Loc) -> int | Refused:
        text = node.value
        if not _INT_12.match(text):  # an explicit !!int on something else
            self.error(node, loc, f"{printable(text)!r} is not a whole number")
            return REFUSED
        sign = -1 if text.startswith("-") else 1
        digits = text.lstrip("+-")
        if digits.startswith(("0x", "0o")):
            value = int(digits[2:], 16 if digits[1] == "x" else 8)
        elif len(digits) > 1 and digits.startswith("0"):
            self.error(node, loc, f"{node.value}: a number with a leading zero is ambiguous "
                       f"(YAML 1.1 reads it as octal); write {int(digits)}")
            return REFUSED
        elif len(digits) > 16:
            self.error(node, loc, f"{digits[:8]}... ({len(digits)} digits) is too large "
                       "(at most about 9e15)")
            return REFUSED
        else:
            value = int(digits)
        if value > MAX_INT:
            self.error(node, loc, f"{node.value} is too large (at most about 9e15)")
            return REFUSED
        return sign * value

    def build_key(self, node: ScalarNode, loc: Loc) -> str | int | None:
        key = self.scalar(node, loc)
        if key is REFUSED:
            return None  # reported
        if isinstance(key, bool) or not isinstance(key, (str, int)):
            # Booleans as keys ("on:", "yes:") are a classic YAML trap; make them explicit.
            self.error(node, loc, f"key {node.value!r} must be a name or a whole number")
            return None
        return key


def _problem(exc: yaml.YAMLError) -> str:
    problem = getattr(exc, "problem", None) or str(exc)
    context = getattr(exc, "context", None)
    return f"{context}, {problem}" if context else str(problem)


def parse_yaml(text: str, file: str) -> tuple[Document, list[Diagnostic]]:
    """Parse ``text`` (named ``file`` in messages): the document and any errors found."""
    doc, diags = _parse(text, file)
    hints = colour_comment_hints(text, file)  # the cause of what the parser says, if any
    return (doc, hints + diags) if hints else (doc, diags)


def _parse(text: str, file: str) -> tuple[Document, list[Diagnostic]]:
    doc = Document(file, None)
    try:
        composed = _compose(text)
    except RecursionError:
        return doc, [_too_deep(text, file)]
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        msg = f"YAML syntax: {_problem(exc)}"
        return doc, [Diagnostic("error", msg, Origin(file, line, col))]
    except yaml.reader.ReaderError as exc:  # a control character, at its place
        line, col = _line_col(text, exc.position)
        char = exc.character if isinstance(exc.character, str) else chr(exc.character)
        msg = (f"the control character {printable(char)} is not allowed in YAML "
               "(a stray byte? write it as an escape in a double-quoted string if meant)")
        return doc, [Diagnostic("error", msg, Origin(file, line, col))]
    except yaml.YAMLError as exc:
        return doc, [Diagnostic("error", f"YAML: {printable(str(exc))}", Origin(file, 1, 1))]
    if isinstance(composed, int):  # past libyaml's 1000 levels: the 65th comes before
        return doc, [_too_deep(text[:composed], file)]
    nodes = composed
    if not nodes:
        return doc, [Diagnostic("error", "the file is empty", Origin(file, 1, 1))]
    if len(nodes) > 1:
        mark = nodes[1].start_mark
        origin = Origin(file, mark.line + 1, mark.column + 1)
        return doc, [Diagnostic("error", "one YAML document per file, found several", origin)]
    root = nodes[0]
    # With an alias ('*name') a value may be built many times over (or contain itself): the
    # nodes are walked first, counting what they expand to. Without one, the builder counts
    # and bounds them itself (a walk of 10^5 nodes is a tenth of reading a long routine).
    if "*" in text:
        deep, count, shared = _walk(root)
        if deep is not None:
            return doc, [_too_deep_at(deep, file)]
        # Without a list or mapping used twice (an alias), the values built are the nodes.
        if (_expanded_size(root, {}, set()) if shared else count) > MAX_NODES:
            return doc, [_too_big(text, file)]
        builder = _Builder(doc, aliases=True)
        doc.data = builder.build(root, ())
        return doc, builder.errors
    builder = _Builder(doc, aliases=False)
    data = builder.build(root, ())
    if builder.inexact:  # a node it did not build, or nesting too deep: the walk says exactly
        deep, count, _ = _walk(root)
        if deep is not None:
            return Document(file, None), [_too_deep_at(deep, file)]
    else:  # every node built once: a value, or a mapping's key
        count = len(doc.marks) + len(doc.key_marks)
    if count > MAX_NODES:
        return Document(file, None), [_too_big(text, file)]
    doc.data = data
    return doc, builder.errors


# libyaml's parser when PyYAML has it: the same nodes and marks, five times faster than the
# pure-Python one (0.7 s -> 0.14 s for benchmarks/compile_speed.py's routine of 290 kB).
_C_LOADER: type[yaml.SafeLoader] | None = getattr(yaml, "CSafeLoader", None)
_FAST_LOADER: type[yaml.SafeLoader] | None = None
if _C_LOADER is not None:
    class _CLoader(_C_LOADER):  # type: ignore[valid-type,misc]
        """libyaml's parser with the same YAML 1.2 number resolvers as :class:`_Loader`."""

        # libyaml's composer calls these for every node it makes (aliases aside); they only
        # serve path resolvers, which no loader here has. C functions that take the same
        # arguments and do nothing cost a tenth of a Python method's call (a quarter of
        # composing a long routine was spent in the two).
        descend_resolver = staticmethod(operator.is_)  # is_(current_node, current_index)
        ascend_resolver = staticmethod(tuple)  # tuple()

        def __init__(self, stream: str) -> None:
            super().__init__(stream)
            # The tag of a node depends only on resolve's arguments (no path resolvers here),
            # and a routine repeats its values (keys, durations, the same numbers): each is
            # resolved once, not by the regular expressions again for every node. The cache
            # is C's (no Python call when it answers) and this loader's (it ends with it).
            self.resolve = functools.lru_cache(maxsize=None)(_RESOLVER.resolve)

    _CLoader.yaml_implicit_resolvers = _Loader.yaml_implicit_resolvers
    _FAST_LOADER = _CLoader


def _compose(text: str) -> list[Node] | int:
    """The documents' nodes; a YAML error is raised by the pure-Python parser, whose messages
    (and marks) the diagnostics are written for, even when libyaml found it first.

    Nesting past libyaml's own limit gives instead the text offset before which it is (the
    pure-Python scanner takes time quadratic in the nesting to say so: 1.5 s of CPU for a line
    of a thousand ``[``)."""
    if _FAST_LOADER is not None:
        try:
            loader: Any = _FAST_LOADER(text)  # a _CLoader
            try:  # yaml.compose_all
                nodes: list[Node] = []
                while loader.check_node():
                    nodes.append(loader.get_node())
            finally:
                loader.dispose()
            return nodes
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark
            if mark is not None and "maximum nesting depth" in str(exc.problem):
                return _offset(text, mark.line, mark.column)
        except yaml.YAMLError:
            pass  # said again below, in the pure-Python parser's words
    return list(yaml.compose_all(text, Loader=_Loader))


def _offset(text: str, line: int, column: int) -> int:
    """The text offset of 0-based ``line`` and ``column`` (in characters, as marks count)."""
    at = 0
    for _ in range(line):
        nxt = text.find("\n", at)
        if nxt < 0:
            return len(text)
        at = nxt + 1
    return min(at + column, len(text))


def _line_col(text: str, position: int) -> tuple[int, int]:
    """1-based line and column of character ``position`` (YAML's line breaks)."""
    head = text[:position]
    lines = re.split("\r\n|[\n\r\x85\u2028\u2029]", head)
    return len(lines), len(lines[-1]) + 1


def _walk(root: Node) -> tuple[Node | None, int, bool]:
    """The first node nested deeper than :data:`MAX_DEPTH` (aliases followed once), or None;
    how many nodes were walked; whether a list or mapping is reached twice (an alias)."""
    stack: list[tuple[Node, int]] = [(root, 1)]
    seen: set[int] = set()
    count = 0
    shared = False
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            return node, count, shared
        count += 1
        if isinstance(node, ScalarNode):
            continue
        if id(node) in seen:
            shared = True
            continue
        seen.add(id(node))
        if isinstance(node, SequenceNode):
            stack.extend((item, depth + 1) for item in reversed(node.value))
        elif isinstance(node, MappingNode):
            for key, value in reversed(node.value):
                stack.append((value, depth + 1))
                stack.append((key, depth + 1))
    return None, count, shared


def _too_deep_at(node: Node, file: str) -> Diagnostic:
    mark = node.start_mark
    return Diagnostic("error", f"the YAML is nested more than {MAX_DEPTH} levels deep here",
                      Origin(file, mark.line + 1, mark.column + 1))


def _expanded_size(node: Node, sizes: dict[int, int], active: set[int]) -> int:
    """How many values ``node`` builds into, each alias use counted in full (memoised per
    node, so a file of shared anchors costs its own size, not its expansion)."""
    known = sizes.get(id(node))
    if known is not None:
        return known
    if id(node) in active or isinstance(node, ScalarNode):
        return 1  # a recursive alias is reported by the builder
    active.add(id(node))
    total = 1
    if isinstance(node, SequenceNode):
        total += sum(_expanded_size(item, sizes, active) for item in node.value)
    elif isinstance(node, MappingNode):
        total += sum(_expanded_size(k, sizes, active) + _expanded_size(v, sizes, active)
                     for k, v in node.value)
    active.discard(id(node))
    sizes[id(node)] = total
    return total


def _too_big(text: str, file: str) -> Diagnostic:
    """The error for a file past :data:`MAX_NODES`, at the alias (or value) that passed it:
    the events are replayed counting what each alias expands to."""
    built = 0
    anchors: dict[str, int] = {}
    open_: list[tuple[str | None, int]] = []  # (anchor, count when the collection started)
    mark = None
    for event in yaml.parse(text, Loader=yaml.SafeLoader):
        if isinstance(event, yaml.AliasEvent):
            built += anchors.get(str(event.anchor), 1)
        elif isinstance(event, (yaml.ScalarEvent, yaml.CollectionStartEvent)):
            built += 1
            if isinstance(event, yaml.CollectionStartEvent):
                open_.append((event.anchor, built - 1))
            elif event.anchor is not None:
                anchors[event.anchor] = 1
        elif isinstance(event, yaml.CollectionEndEvent) and open_:
            anchor, before = open_.pop()
            if anchor is not None:
                anchors[anchor] = built - before
            continue
        else:
            continue
        if built > MAX_NODES:
            mark = event.start_mark
            break
    line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
    kind = "this alias" if isinstance(event, yaml.AliasEvent) else "the file"
    return Diagnostic("error", f"{kind} makes the YAML expand to more than {MAX_NODES:,} values "
                      "(aliases of aliases?): a routine is far smaller", Origin(file, line, col))


def _too_deep(text: str, file: str) -> Diagnostic:
    """The error for nesting too deep for the YAML composer, at the collection that passed
    :data:`MAX_DEPTH` (found from the parser's events, which do not recurse)."""
    depth = 0
    line = col = 1
    try:  # libyaml's events when it is there (the pure-Python scanner is quadratic here)
        for event in yaml.parse(text, Loader=_FAST_LOADER or _Loader):
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_DEPTH:
                    mark = event.start_mark
                    line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
                    break
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
    except yaml.YAMLError:
        pass
    return Diagnostic("error", f"the YAML is nested more than {MAX_DEPTH} levels deep here",
                      Origin(file, line, col))


def read_text(path: Path) -> str | tuple[str] | Diagnostic:
    """The file's text; ``(reason,)`` when it cannot be opened or read (missing, a pipe or a
    device, too large, ...); a diagnostic at the place of a byte that is not UTF-8."""
    try:
        return read_text_file(path, limit=MAX_ROUTINE_BYTES)
    except FileAccessError as exc:
        if (exc.line, exc.column) != (1, 1) or str(exc).startswith("not UTF-8"):
            return Diagnostic("error", str(exc), Origin(str(path), exc.line, exc.column))
        return (str(exc),)


def read_yaml(path: Path, file: str | None = None) -> tuple[Document, list[Diagnostic]]:
    """Read and parse ``path``; an unreadable file is one diagnostic, never an exception."""
    name = file if file is not None else str(path)
    text = read_text(path)
    if isinstance(text, Diagnostic):
        assert text.origin is not None
        origin = Origin(name, text.origin.line, text.origin.column)
        return Document(name, None), [Diagnostic("error", text.message, origin)]
    if isinstance(text, tuple):
        return Document(name, None), [Diagnostic("error", text[0], Origin(name, 1, 1))]
    return parse_yaml(text, name)
