"""The XGO family: the Mini, Lite and Rider, which speak the XGO register protocol.

:mod:`~xgo_show.families.xgo.family` holds the family object; the other modules hold what is
the XGO protocol's own and belongs to no other layer: the reset action and the posture it
restores, stop and rest frames, telemetry requests and the pre-flight check.
"""
