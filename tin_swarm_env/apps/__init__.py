"""Layer 3: the applications over the env and the policies' public API: the ``tin-swarm`` CLI
(:mod:`.cli`), the episode loop (:mod:`.rollout`), ``run`` tables (:mod:`.run`), GIF/MP4 writing
(:mod:`.media`), policy evaluation (:mod:`.evaluate`), the PPO training entry (:mod:`.train`), the
field explorer (:mod:`.explorer`) and the dataclass-to-argparse helper (:mod:`.args`). Import the
submodules; this package imports nothing on its own."""
