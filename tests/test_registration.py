"""Registration with PettingZoo and Gymnasium (_registration.py): the post-import hook, and the ids
registered once the frameworks are imported."""

from __future__ import annotations

import sys


def test_on_import_runs_callbacks_once_after_the_module_executed(tmp_path, monkeypatch):
    from tin_swarm_env._registration import _on_import

    (tmp_path / "tse_probe_mod.py").write_text("VALUE = 41\nVALUE += 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    seen = []
    _on_import("tse_probe_mod", lambda m: seen.append(m.VALUE))
    assert seen == []
    import tse_probe_mod  # noqa: F401

    assert seen == [42]
    _on_import("tse_probe_mod", lambda m: seen.append(-m.VALUE))  # already imported: at once
    assert seen == [42, -42]
    from tin_swarm_env._registration import _PostImportFinder

    assert not any(isinstance(f, _PostImportFinder) for f in sys.meta_path)  # steps aside when done
