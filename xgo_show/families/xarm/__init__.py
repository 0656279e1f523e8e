"""The xArm family: the Hiwonder/LewanSoul xArm and its packet protocol (servos, no registers).

:mod:`~xgo_show.families.xarm.family` holds the family object; :mod:`.runtime` what is the xArm's
own at run time: GroupStop, the unsafe-command check, battery telemetry and the pre-flight check.
"""
