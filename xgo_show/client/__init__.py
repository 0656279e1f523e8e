"""Robot clients: request/response over a transport, for pre-flight checks and telemetry.

- :class:`XgoClient` reads and writes an XGO robot's registers by name;
- :class:`XarmClient` reads the xArm's battery voltage and servo positions;
- :func:`open_client` opens a URL and returns the right client, identifying an XGO robot's
  model from its firmware string when none is given.
"""

from __future__ import annotations

from xgo_show.client.base import DEFAULT_TIMEOUT
from xgo_show.client.connect import model_hint, open_client
from xgo_show.client.xarm import XarmClient
from xgo_show.client.xgo import XgoClient

__all__ = ["DEFAULT_TIMEOUT", "XarmClient", "XgoClient", "model_hint", "open_client"]
