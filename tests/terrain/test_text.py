"""The line tokenizer of the text terrain formats (terrain/_text.py)."""

from __future__ import annotations

import numpy as np
import pytest

from tin_swarm_env.errors import DemFormatError


def test_the_shared_line_tokenizer_skips_comments_and_blank_lines_and_reads_commas(tmp_path):
    from tin_swarm_env.terrain._text import numeric_rows

    p = tmp_path / "t.xyz"
    p.write_text("# header\n\n1,2, 3  # c\n  4 5 nan\n")
    rows = [(i, v) for i, v, _ in numeric_rows(p, "x y z", DemFormatError)]
    assert rows[0] == (3, [1.0, 2.0, 3.0]) and rows[1][0] == 4 and rows[1][1][:2] == [4.0, 5.0]
    assert np.isnan(rows[1][1][2]) and len(rows) == 2
    p.write_text("1 2 3\n1 2\n")
    with pytest.raises(DemFormatError, match=r"t\.xyz:2: expected 3 numbers 'x y z', found 2: '1 2'"):
        list(numeric_rows(p, "x y z", DemFormatError))


def test_a_word_where_a_number_belongs_is_named_with_its_line_and_the_caller_s_error(tmp_path):
    from tin_swarm_env.errors import TinFormatError
    from tin_swarm_env.terrain._text import numeric_rows

    p = tmp_path / "m.tin"
    p.write_text("0 0 1\n1 0 1\n0 one 1\n")
    rows = numeric_rows(p, "x y z", TinFormatError)
    assert next(rows)[:2] == (1, [0.0, 0.0, 1.0])  # rows come one at a time, before the bad line is read
    with pytest.raises(TinFormatError, match=r"m\.tin:3: not a number in '0 one 1'"):
        list(rows)
    p.write_text("1 2 inf -inf\n")
    assert [v for _, v, _ in numeric_rows(p, "a b c d", TinFormatError)] == [[1.0, 2.0, np.inf, -np.inf]]
