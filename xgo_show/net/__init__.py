"""Networked shows over Eclipse Zenoh: sessions, messages, time sync, show clocks.

- :mod:`xgo_show.net.session`: one way to open a Zenoh session from Zenoh's own options
  (``--connect``, ``--listen``, ``--zenoh-config``) with safe single-machine defaults;
- :mod:`xgo_show.net.messages`: the versioned JSON payloads conductors and relays exchange;
- :mod:`xgo_show.net.keys`: the key expressions under the namespace;
- :mod:`xgo_show.net.offset` and :mod:`xgo_show.net.slew`: clock offset and drift estimates,
  and the relay's show clock that follows them.

Importing this package does not import ``zenoh``; the modules that need it do.
"""

from __future__ import annotations
