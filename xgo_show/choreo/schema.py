"""The JSON schemas of routine files and included part files, from the pydantic models.

Editors that speak the YAML language server use them through a modeline on the first line:
``# yaml-language-server: $schema=../schemas/choreography.schema.json`` for a routine, and
``...$schema=../../schemas/choreography-part.schema.json`` for a part (an included file: a list
of cues, or a mapping with phrases, cues and optionally params). Regenerate with
``python -m xgo_show.choreo.schema > schemas/choreography.schema.json`` and
``python -m xgo_show.choreo.schema --part > schemas/choreography-part.schema.json``.
"""

from __future__ import annotations

import json
import sys
from typing import Any

from pydantic import TypeAdapter

from xgo_show.choreo.model import CueModel, ParamPartMapping, PartMapping, ShowFile

__all__ = [
    "PART_SCHEMA_ID",
    "SCHEMA_ID",
    "choreography_json_schema",
    "choreography_part_json_schema",
    "main",
]

SCHEMA_ID = "https://xgo-show.invalid/schemas/choreography.schema.json"
PART_SCHEMA_ID = "https://xgo-show.invalid/schemas/choreography-part.schema.json"


def choreography_json_schema() -> dict[str, Any]:
    """The JSON schema (draft 2020-12) of a routine file."""
    schema = ShowFile.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = SCHEMA_ID
    schema["title"] = "xgo-show routine"
    return schema


def choreography_part_json_schema() -> dict[str, Any]:
    """The JSON schema of an included part file: a list of cues, or phrases and cues (and
    parameters, whose ``$name`` uses make its cues checkable only once values are given)."""
    adapter: TypeAdapter[list[CueModel] | PartMapping | ParamPartMapping] = TypeAdapter(
        list[CueModel] | PartMapping | ParamPartMapping
    )
    schema = adapter.json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = PART_SCHEMA_ID
    schema["title"] = "xgo-show routine part (included file)"
    return schema


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if args not in ([], ["--part"]):
        print("usage: python -m xgo_show.choreo.schema [--part]", file=sys.stderr)
        return 2
    schema = choreography_part_json_schema() if args else choreography_json_schema()
    json.dump(schema, sys.stdout, indent=2, sort_keys=True)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
