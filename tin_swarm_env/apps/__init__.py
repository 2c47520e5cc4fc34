"""Layer 4, the ``tin-swarm`` commands only (parse ``Args``, call a library, print and write).

The command line (:mod:`.cli`), ``run`` tables (:mod:`.run`), GIF/MP4 writing (:mod:`.media`,
:mod:`.gif`), ``eval`` (:mod:`.evaluate`) and its standard suite (:mod:`.suite`), ``train``
(:mod:`.train`), the field explorer (:mod:`.explorer`, :mod:`.explorer_view`,
:mod:`.explorer_controls`), ``scenarios`` and ``build-tin``, and the dataclass-to-argparse helper
(:mod:`.args`). The training library they call is :mod:`tin_swarm_env.training`. Import the
submodules; this package imports nothing on its own."""
