"""The documentation's generated tables (docs/gen_tables.py): each committed file equals a fresh
generation, and what the generator reads agrees with the code it documents. Rewrite the files with

    TIN_SWARM_WRITE_DOCS=1 python -m pytest tests/integration/test_docs_tables.py
"""

from __future__ import annotations

import dataclasses
import importlib.util
import re
from pathlib import Path

import pytest

from tin_swarm_env.errors import ScenarioError
from tin_swarm_env.scenario import scenario_from_dict
from tin_swarm_env.scenario.config import COMMON_TERRAIN_KEYS, SOURCE_KEYS

ROOT = Path(__file__).resolve().parents[2]


def _gen():
    spec = importlib.util.spec_from_file_location("gen_tables", ROOT / "docs" / "gen_tables.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


GEN = _gen()


@pytest.mark.parametrize("relpath", sorted(GEN.TABLES))
def test_generated_file_is_current(relpath, generated_doc):
    generated_doc(relpath, GEN.TABLES[relpath]())


def test_every_generated_file_is_included_by_a_page():
    pages = "".join(p.read_text() for p in (ROOT / "docs").glob("*.md"))
    for relpath in GEN.TABLES:
        assert f'--8<-- "{relpath}"' in pages, relpath


def _known_keys(table: str) -> set[str]:
    """The keys the parser accepts in ``table`` (from its unknown-key error, which lists them)."""
    doc = {"terrain": {"source": "flat"}, "targets": {"positions": [[1.0, 1.0]]}}
    if table:
        doc[table] = {**doc.get(table, {}), "no_such_key": 1}
    else:
        doc["no_such_key"] = 1
    with pytest.raises(ScenarioError, match="unknown key 'no_such_key'") as err:
        scenario_from_dict(doc, source="t.toml")
    return set(re.search(r"known: ([^)]*)\)", str(err.value)).group(1).split(", "))


@pytest.mark.parametrize("table", [t for t, _ in GEN.scenario_tables()])
def test_scenario_keys_page_lists_exactly_the_keys_the_parser_takes(table):
    """Every key the parser names as known is documented, and every documented key is accepted with
    its documented default."""
    classes = dict(GEN.scenario_tables())[table]
    nested = {t for t, _ in GEN.scenario_tables() if t}
    documented = {}
    for cls, excluded in classes:
        for f in dataclasses.fields(cls):
            if f.name not in excluded:
                documented[f.name] = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    known = _known_keys(table) - (nested | {"description"} if not table else set())
    assert known <= set(documented), known - set(documented)
    for key, default in documented.items():
        if default in (None, ()) or (table, key) == ("", "name"):
            continue
        if table == "terrain" and key not in (*COMMON_TERRAIN_KEYS, *SOURCE_KEYS["flat"]):
            # the other [terrain] keys are read by other sources only (a flat plane refuses them):
            # each must be read by at least one source
            assert any(key in keys for keys in SOURCE_KEYS.values()), key
            continue
        doc = {"terrain": {"source": "flat"}, "targets": {"positions": [[1.0, 1.0]]}}
        where = doc.setdefault(table, {}) if table else doc
        where[key] = list(default) if isinstance(default, tuple) else default
        scenario_from_dict(doc, source="t.toml")  # accepted


def test_field_docs_reads_name_description_lines_and_their_continuations():
    @dataclasses.dataclass
    class Demo:
        """Intro line mentioning alpha  in passing.

        alpha     first field,
                  continued here
        beta_m    second
        gamma is not listed like that
        """

        alpha: int = 0
        beta_m: float = 0.0
        gamma: str = ""

    assert GEN.field_docs(Demo) == {"alpha": "first field, continued here", "beta_m": "second"}


def test_rst_table_parser_and_the_observation_check():
    doc = """Intro.

    =====  ====  ========
    name   size  contents
    =====  ====  ========
    a      1     first
    b      2     second,
                 wrapped
    =====  ====  ========

    After.
    """
    before, rows, after = GEN.rst_simple_table(doc)
    assert rows == [("a", "1", "first"), ("b", "2", "second, wrapped")]
    assert before == ["Intro.", ""] and after == ["", "After."]
    assert GEN.md_inline("``x`` and :class:`~a.b.C` and :mod:`a.b`") == "`x` and `C` and `a.b`"


def test_observation_table_refuses_a_docstring_that_disagrees_with_obslayout(monkeypatch):
    from tin_swarm_env.env import observation as ob

    monkeypatch.setattr(ob, "__doc__", ob.__doc__.replace("own.speed            1", "own.speed            3"))
    with pytest.raises(ValueError, match="own.speed size '3'"):
        GEN.observation_table()
    monkeypatch.setattr(ob, "__doc__", ob.__doc__.replace("own.tilt ", "own.tlit "))
    with pytest.raises(ValueError, match="own.tlit"):
        GEN.observation_table()


def test_observation_table_columns_are_obslayout_slices():
    from tin_swarm_env.env.observation import DEFAULT_K_ASSETS, ObsLayout

    lay = ObsLayout(k_assets=DEFAULT_K_ASSETS)
    text = GEN.observation_table()
    assert f"| `breaks` | {lay.breaks.start}..{lay.breaks.stop - 1} |" in text
    assert f"| `own.target_dz` | {lay.own['target_dz'].start}..{lay.own['target_dz'].start} |" in text
    assert f"d = {ObsLayout().size} without assets" in text


def test_readme_apf_table_is_the_generated_one():
    """README's APF table is docs/generated/apf_summary.md's (both read off docs/figures/apf.md); a
    README edited by hand, or a bench run whose figures README does not show, fails here."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- apf-table:start -->\n(.*?)<!-- apf-table:end -->", text, re.S)
    assert block is not None, "README.md has no apf-table block"
    assert block.group(1) == GEN.apf_summary_rows()
    assert "| generated: fork |" in block.group(1) and "| jacksboro, given 1800 steps |" in block.group(1)


def test_readme_speed_line_is_the_generated_one():
    """README's speed line is read off docs/figures/world.md and env.md (2 threads):
    ``python docs/gen_tables.py`` rewrites it after a bench run."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- speed:start -->\n(.*?)<!-- speed:end -->", text, re.S)
    assert block is not None, "README.md has no speed block"
    assert block.group(1) == GEN.speed_summary()
    assert "robot-steps/s at 1 000 robots" in block.group(1) and "% at 1 000 robots" in block.group(1)


def test_readme_suite_line_is_the_generated_one():
    """README's standard-suite line quotes the APF row of docs/figures/standard_suite.md."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- suite-apf:start -->\n(.*?)<!-- suite-apf:end -->", text, re.S)
    assert block is not None, "README.md has no suite-apf block"
    assert block.group(1) == GEN.suite_apf_line()
    assert "the default APF brings" in block.group(1) and "% of the robots in" in block.group(1)
