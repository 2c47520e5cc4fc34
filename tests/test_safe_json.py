"""Reading a JSON file that may be hostile: size and nesting depth checked before parsing, NaN and
Infinity refused, every failure one error naming the file."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env._safe_json import json_depth, read_json
from tin_swarm_env.errors import CheckpointError, TinSwarmError

json_values = st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False, allow_infinity=False)
                           | st.text(), lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(), c, max_size=3),
                           max_leaves=20)


def _depth(v) -> int:
    if isinstance(v, list):
        return 1 + max((_depth(x) for x in v), default=0)
    if isinstance(v, dict):
        return 1 + max((_depth(x) for x in v.values()), default=0)
    return 0


@settings(max_examples=200, deadline=None)
@given(json_values)
def test_the_depth_scan_agrees_with_the_parsed_value(v):
    """Brackets inside strings (escaped quotes included) are not counted."""
    assert json_depth(json.dumps(v)) == _depth(v)


def test_a_good_file_reads_back(tmp_path):
    p = tmp_path / "a.json"
    tricky = '[{\\"}'  # brackets, a backslash and a quote inside a string
    p.write_text(json.dumps({"a": [1, 2.5, {"b": tricky}]}))
    assert read_json(p, max_bytes=1000) == {"a": [1, 2.5, {"b": tricky}]}


@pytest.mark.parametrize("content,msg", [
    ("[" * 40 + "]" * 40, "nested 40 levels deep; at most 32"),
    ("[" * 200_000, "nested 200000 levels deep"),
    ('{"a": NaN}', "not valid JSON"),
    ('{"a": Infinity}', "not valid JSON"),
    ('{"a": ', "not valid JSON"),
    (b"\xff\xfe", "cannot be read"),
    ("x" * 2_000_001, "more than the 2,000,000 such a file may have"),
])
def test_a_hostile_file_is_one_error_naming_it(tmp_path, content, msg):
    p = tmp_path / "h.json"
    (p.write_bytes if isinstance(content, bytes) else p.write_text)(content)
    with pytest.raises(CheckpointError) as ei:
        read_json(p, max_bytes=2_000_000, exc=CheckpointError)
    assert str(ei.value).startswith(f"{p}: ") and msg in str(ei.value) and "\n" not in str(ei.value)


def test_a_directory_or_missing_file_is_named(tmp_path):
    with pytest.raises(TinSwarmError, match="is a directory"):
        read_json(tmp_path, max_bytes=10)
    with pytest.raises(TinSwarmError, match="is missing"):
        read_json(tmp_path / "nope.json", max_bytes=10)
