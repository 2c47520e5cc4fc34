"""tin_swarm_env/apps/evaluate.py: ``tin-swarm eval`` says which files it wrote (and its Python API
returns them), and its bar plot's axes and legend read at a glance."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tin_swarm_env.apps.cli import main
from tin_swarm_env.apps.evaluate import METRICS, Args, bar_figure, evaluate
from tin_swarm_env.errors import ArgumentError


def test_eval_prints_and_returns_every_file_it_writes(tmp_path, capsys):
    out = tmp_path / "e"
    rows = evaluate(Args(scenarios="flat", seeds=1, robots=2, policies="apf", out=str(out)))
    want = [out.with_suffix(".md"), out.with_suffix(".csv"), out.with_suffix(".png")]
    assert rows.files == want and all(p.is_file() and p.stat().st_size > 0 for p in want)
    assert [r["policy"] for r in rows] == ["apf"]  # still the rows
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-3:] == [f"wrote {p}" for p in want]  # at the end, one path a line
    assert sorted(tmp_path.iterdir()) == sorted(want)  # nothing else (no .part file left)


def test_the_command_line_prints_the_files_and_needs_a_scenario_or_a_suite(tmp_path, capsys):
    assert main(["eval", "flat", "--seeds", "1", "--robots", "2", "--policies", "random", "--out",
                 str(tmp_path / "c")]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out[-3:] == [f"wrote {tmp_path / 'c'}{ext}" for ext in (".md", ".csv", ".png")]
    assert main(["eval", "--policies", "random", "--out", str(tmp_path / "d")]) == 2
    assert "give at least one scenario (or --suite standard)" in capsys.readouterr().err
    with pytest.raises(ArgumentError, match="--quick applies to --suite only"):
        evaluate(Args(scenarios="flat", quick=True, out=str(tmp_path / "q")))
    with pytest.raises(ArgumentError, match="run_suite"):
        evaluate(Args(suite="standard", out=str(tmp_path / "s")))
    assert not list(tmp_path.glob("[dqs]*"))


def _rows(fell=0.0, ret=0.0):
    rows = []
    for scen in ("ramp", "hill"):
        for k, pol in enumerate(("random", "apf", "a-long-policy-name")):
            r = {"scenario": scen, "policy": pol}
            for key, _, _ in METRICS:
                r[key], r[key + "_ci95"] = 0.0, 0.0
            r["arrived"], r["arrived_ci95"] = 0.3 * k, 0.05
            r["fell"], r["return"] = fell, ret
            rows.append(r)
    return rows


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_rate_panels_show_0_to_100_percent_even_when_all_zero_and_the_legend_covers_no_bar():
    fig = bar_figure(_rows(fell=0.0, ret=0.0))
    arrived, falls, ret = fig.axes[:3]
    for ax in (arrived, falls):
        lo, hi = ax.get_ylim()
        assert lo == 0.0 and hi >= 1.0  # the whole share, not -0.04..0.04 round an all-zero panel
        labels = [t.get_text() for t in ax.get_yticklabels()]
        assert labels[0] == "0%" and "100%" in labels
    lo, hi = ret.get_ylim()
    assert lo <= -1.0 + 1e-9 and hi >= 1.0 - 1e-9  # no spread: a fixed range round 0
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert len(fig.legends) == 1
    legend = fig.legends[0].get_window_extent(renderer)
    for ax in fig.axes[:3]:
        assert not _overlap(legend, ax.get_window_extent(renderer))  # beside the panels, over no bar
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["random", "apf", "a-long-policy-name"]
    # each rate bar carries its value
    assert "60%" in [t.get_text() for t in arrived.texts]
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_a_return_panel_with_spread_keeps_its_own_scale():
    import matplotlib.pyplot as plt

    fig = bar_figure(_rows(fell=0.02, ret=-40.0))
    lo, hi = fig.axes[2].get_ylim()
    assert lo < -40.0 and hi >= 0.0
    assert fig.axes[1].get_ylim() == (0.0, pytest.approx(1.12))
    plt.close(fig)


def test_bar_plot_writes_a_png(tmp_path):
    from tin_swarm_env.apps.evaluate import bar_plot

    p = bar_plot(_rows(), tmp_path / "b.png")
    assert p == Path(tmp_path / "b.png") and p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert np.all([not f.name.endswith(".part.png") for f in tmp_path.iterdir()])
