"""Show control: sections released by triggers, and the documented Zenoh control API.

:class:`~xgo_show.control.director.Director` holds a running show at its waits and releases
it on triggers; :mod:`~xgo_show.control.script` plays triggers from a timed script (rehearsals);
the Zenoh server and its thin clients (``xgo-show serve``, ``ctl``, ``trigger``) are in the
other modules of this package (docs/zenoh-api.md).
"""
