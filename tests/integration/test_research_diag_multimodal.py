"""research/diag_multimodal.py (run by hand, research/teacher_multimodal.md): its side-flip count is
the hand-computed one."""

import numpy as np
import pytest


@pytest.fixture
def diag(repo_script):
    return repo_script("research/diag_multimodal.py")


def test_side_flips_count_changes_between_nonzero_sides_of_live_rows(diag):
    """Rows over 5 steps: + 0 - - + (2 flips: a 0 keeps the last side), - - - - - (0), + - + - +
    with the row not live at steps 1 and 2 (the changes at steps 1, 2 not counted, the last side still
    updated: 2 flips, at steps 3 and 4)."""
    sides = np.array([[1, -1, 1], [0, -1, -1], [-1, -1, 1], [-1, -1, -1], [1, -1, 1]])
    live = np.ones((5, 3), bool)
    live[1:3, 2] = False
    last, total, per_row = np.zeros(3), 0, np.zeros(3, int)
    for t in range(5):
        for j in range(3):
            per_row[j] += diag.side_flips(sides[t, j:j + 1], last[j:j + 1], live[t, j:j + 1])[0]
        k, last = diag.side_flips(sides[t], last, live[t])
        total += k
    assert per_row.tolist() == [2, 0, 2] and total == 4
    np.testing.assert_array_equal(last, [1, -1, 1])
