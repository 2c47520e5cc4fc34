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
