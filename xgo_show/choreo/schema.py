"""The JSON schema of routine files, generated from the pydantic models.

Editors that speak the YAML language server use it through the modeline
``# yaml-language-server: $schema=../schemas/choreography.schema.json``. Regenerate with
``python -m xgo_show.choreo.schema > schemas/choreography.schema.json``.
"""

from __future__ import annotations

import json
import sys
from typing import Any

from xgo_show.choreo.model import ShowFile

__all__ = ["SCHEMA_ID", "choreography_json_schema", "main"]

SCHEMA_ID = "https://xgo-show.invalid/schemas/choreography.schema.json"


def choreography_json_schema() -> dict[str, Any]:
    """The JSON schema (draft 2020-12) of a routine file."""
    schema = ShowFile.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = SCHEMA_ID
    schema["title"] = "xgo-show routine"
    return schema


def main() -> int:
    json.dump(choreography_json_schema(), sys.stdout, indent=2, sort_keys=True)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
