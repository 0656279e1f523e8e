"""The built-in profiles built again, within a test, by their modules' code.

The registry's profiles are built once, when ``xgo_show.profiles`` is first imported. The table
tests check profiles built within the test instead, so that they check the code that builds the
tables and not only the one result of it kept since the import: mutation testing
(docs/contributing.md) changes that code after the import, and a test of the import-time
profile would never see the change. Never compare a built profile with the registry's: under
mutation that comparison fails for any change at all, whether or not a test states the property
it breaks.
"""

from __future__ import annotations

import functools
import importlib.util
from importlib.machinery import ModuleSpec
from types import CodeType

from xgo_show.profiles import Profile

# model -> (module under xgo_show.profiles, the profile's name in it)
_BUILT_IN = {
    "mini": ("xgo_dog", "MINI"),
    "lite": ("xgo_dog", "LITE"),
    "rider": ("xgo_rider", "RIDER"),
    "xarm": ("xarm", "XARM"),
}


@functools.cache
def _module_code(name: str) -> tuple[ModuleSpec, CodeType]:
    # Compiled once: loading it is what costs (seconds for mutmut's copy of a module, which
    # holds every mutant); running it again is cheap.
    spec = importlib.util.find_spec(name)
    assert spec is not None and spec.loader is not None
    code = spec.loader.get_code(name)  # type: ignore[attr-defined]
    assert isinstance(code, CodeType)
    return spec, code


def build_profile(model: str) -> Profile:
    """``model``'s built-in profile, built now by running its module again (in a fresh module
    object that is not entered in ``sys.modules``: the registry keeps its own)."""
    module_name, attribute = _BUILT_IN[model]
    spec, code = _module_code(f"xgo_show.profiles.{module_name}")
    module = importlib.util.module_from_spec(spec)
    exec(code, module.__dict__)
    profile = getattr(module, attribute)
    assert isinstance(profile, Profile)
    return profile
