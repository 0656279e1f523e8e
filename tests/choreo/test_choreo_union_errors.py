"""A value that fits one branch of a union's types gets that branch's complaint only."""

from __future__ import annotations

import pytest

from xgo_show.choreo import validate_file

from .conftest import WriteFn


@pytest.mark.parametrize(("cue", "message"), [
    ("{action: 99999}", "99999 is too large: give 0 to 255"),
    ("{action: ''}", "'' is empty: give at least 1 character"),
    ("{move: {pitch: .nan}, duration: 1}", ".nan is not a number: give a finite number"),
    ("{move: {pitch: .inf}, duration: 1}", ".inf is infinite: give a finite number"),
    ("{move: {pitch: [1, .nan]}, duration: 1}", ".nan is not a number: give a finite number"),
])
def test_one_error_for_one_mistake(write: WriteFn, cue: str, message: str) -> None:
    path = write(f"""
        show: S
        performers:
          rex: {{model: mini}}
        tracks:
          rex:
            - {cue}
        """)
    errors = [d.message for d in validate_file(path) if d.is_error]
    assert len(errors) == 1 and errors[0].startswith(message), errors


def test_a_value_of_no_branch_names_every_branch(write: WriteFn) -> None:
    path = write("""
        show: S
        performers:
          rex: {model: mini}
        tracks:
          rex:
            - {move: {pitch: true}, duration: 1}
        """)
    errors = [d.message for d in validate_file(path) if d.is_error]
    assert errors == ["should be a number or a list, not True"]
