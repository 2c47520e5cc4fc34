"""Layer 3, the training library on the env and the vector env, importable without the CLI.

The configuration of a run (:mod:`.config`), SB3 PPO with an imitation warm start (:mod:`.sb3`),
imitation and DAgger (:mod:`.imitation`, :mod:`.student`), recurrent students
(:mod:`.recurrent_imitation`), teachers (:mod:`.apf_teacher`), checkpoints (:mod:`.checkpoint`), the
episode loop and trajectories (:mod:`.rollout`, :mod:`.trajectory`), policies by name
(:mod:`.policy_factory`), evaluation rows (:mod:`.evaluation`, :mod:`.scoring`) and the standard
evaluation suite (:mod:`.suite`). It imports no ``tin_swarm_env.apps`` module; the ``tin-swarm``
commands (:mod:`tin_swarm_env.apps`) call it. Import the submodules; this package imports nothing on
its own."""
