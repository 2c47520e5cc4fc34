"""Running episodes (apps/run.py): frames handed to a writer as they come, and the progress bar."""

from __future__ import annotations


def test_run_hands_frames_to_the_writer_without_keeping_them(tmp_path):
    from tin_swarm_env.apps.run import run_episodes

    got = []
    stats, frames = run_episodes("flat", robots=2, max_cycles=6, frames_every=2, progress=False,
                                 render_width=64, on_frame=lambda f: got.append(f.shape))
    assert frames == [] and len(got) == 4 and got[0][1] == 64  # steps 0, 2, 4 and the end
    _, kept = run_episodes("flat", robots=2, max_cycles=6, frames_every=2, progress=False, render_width=64)
    assert len(kept) == 4


def test_progress_bar_is_tqdm():
    import tqdm

    from tin_swarm_env.apps.run import progress_bar

    bar = progress_bar(10, "x")
    assert isinstance(bar, tqdm.tqdm)
    bar.close()
    assert progress_bar(10, "x", enabled=False) is None
