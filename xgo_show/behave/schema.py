"""The JSON schema of behaviour files, from the pydantic model.

Editors that speak the YAML language server use it through a modeline on the first line:
``# yaml-language-server: $schema=../../schemas/behaviour.schema.json``. Regenerate with
``python -m xgo_show.behave.schema > schemas/behaviour.schema.json``.
"""

from __future__ import annotations

import json
import sys
from typing import Any

from xgo_show.behave.model import BehaviourFile

__all__ = ["BEHAVIOUR_SCHEMA_ID", "behaviour_json_schema", "main"]

BEHAVIOUR_SCHEMA_ID = "https://xgo-show.invalid/schemas/behaviour.schema.json"


def behaviour_json_schema() -> dict[str, Any]:
    """The JSON schema (draft 2020-12) of a behaviour file."""
    schema = BehaviourFile.model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = BEHAVIOUR_SCHEMA_ID
    schema["title"] = "xgo-show behaviour"
    return schema


def main(argv: list[str] | None = None) -> int:
    if (sys.argv[1:] if argv is None else argv):
        print("usage: python -m xgo_show.behave.schema", file=sys.stderr)
        return 2
    json.dump(behaviour_json_schema(), sys.stdout, indent=2, sort_keys=True)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
