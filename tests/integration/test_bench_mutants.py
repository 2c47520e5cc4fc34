"""bench/mutants.py (run by hand) plants bugs by text replacement; these fast checks keep every
planted change applicable to today's code, so a rewrite of a kernel cannot silently void a mutant."""

import importlib.util
import sys
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _mutants():
    spec = importlib.util.spec_from_file_location("bench_mutants", ROOT / "bench" / "mutants.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("bench_mutants", mod)  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


def test_every_planted_change_applies_exactly_once_and_names_existing_tests():
    mod = _mutants()
    assert len(mod.MUTANTS) >= 50
    assert mod.stale_mutants() == []


def test_a_stale_pattern_and_a_missing_test_file_are_reported_by_name():
    mod = _mutants()
    m = next(m for m in mod.MUTANTS if mod.stale_mutants([m]) == [])
    gone = replace(m, id="gone", old="this text is in no module")
    lost = replace(m, id="lost", tests=("tests/env/test_no_such_file.py",))
    lines = mod.stale_mutants([gone, lost])
    assert len(lines) == 2
    assert "mutant gone:" in lines[0] and "occurs 0 times" in lines[0] and m.path in lines[0]
    assert lines[1] == "mutant lost: its test file tests/env/test_no_such_file.py does not exist"
