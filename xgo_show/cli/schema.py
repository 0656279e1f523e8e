"""``xgo-show schema``: the JSON Schemas of routine and part files, from the installed package.

An editor that speaks the YAML language server checks a routine against them (a modeline on
the first line: ``# yaml-language-server: $schema=choreography.schema.json``), also outside
this repository: the schemas come from the package's own models, so they always match the
xgo-show that will load the file.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from xgo_show.errors import FileAccessError

__all__ = ["add_parser", "run"]

NAMES = {"routine": "choreography.schema.json", "part": "choreography-part.schema.json"}


def add_parser(sub: Any) -> None:
    """Register the ``schema`` subcommand."""
    parser = sub.add_parser(
        "schema",
        help="print or write the JSON Schemas of routine files",
        description=(
            "Print the JSON Schema of a routine (or, with --part, of an included part file), or "
            "write both into a folder with --write, for editors that check YAML against a schema."
        ),
        epilog=(
            "example:\n"
            "  xgo-show schema > choreography.schema.json\n"
            "  xgo-show schema --write schemas/"
        ),
    )
    parser.add_argument("--part", action="store_true", help="the schema of an included part file")
    parser.add_argument(
        "--write", metavar="FOLDER", help=f"write {' and '.join(NAMES.values())} into FOLDER"
    )
    parser.set_defaults(func=run)


def _text(kind: str) -> str:
    from xgo_show.choreo.schema import choreography_json_schema, choreography_part_json_schema

    schema = choreography_part_json_schema() if kind == "part" else choreography_json_schema()
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


def run(args: argparse.Namespace) -> int:
    """Entry point of ``xgo-show schema``."""
    if args.write is None:
        sys.stdout.write(_text("part" if args.part else "routine"))
        return 0
    folder = Path(args.write)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for kind, name in NAMES.items():
            (folder / name).write_text(_text(kind), encoding="utf-8")
    except OSError as exc:
        why = exc.strerror or exc
        raise FileAccessError(f"cannot write the schemas into {folder}: {why}") from exc
    print(f"wrote {', '.join(str(folder / n) for n in NAMES.values())}")
    return 0
