"""Registration with PettingZoo and Gymnasium (_registration.py): the post-import hook, and the ids
registered once the frameworks are imported."""

from __future__ import annotations

import sys


def test_on_import_runs_callbacks_once_after_the_module_executed(tmp_path, monkeypatch):
    import gymnasium  # noqa: F401  the package's own registrations run first: the hook waits for nothing else
    import pettingzoo  # noqa: F401

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


def test_the_ids_are_registered_once_with_their_entry_point_strings():
    import gymnasium
    import pettingzoo

    from tin_swarm_env._registration import CENTRAL_ID, ENV_ID, SINGLE_ID, register_gymnasium, register_pettingzoo

    assert gymnasium.registry[SINGLE_ID].entry_point == "tin_swarm_env.adapters.gym_views:TinSwarmSingleEnv"
    assert gymnasium.registry[CENTRAL_ID].entry_point == "tin_swarm_env.adapters.gym_views:TinSwarmCentralEnv"
    assert gymnasium.registry[SINGLE_ID].max_episode_steps is None
    if hasattr(pettingzoo, "register"):
        assert pettingzoo.parallel_registry[ENV_ID].entry_point == "tin_swarm_env.tin_swarm_v0:parallel_env"
        assert pettingzoo.aec_registry[ENV_ID].entry_point == "tin_swarm_env.tin_swarm_v0:env"
    before = dict(gymnasium.registry)
    register_gymnasium()  # again: nothing changes, no warning about re-registering
    register_pettingzoo()
    assert dict(gymnasium.registry) == before
