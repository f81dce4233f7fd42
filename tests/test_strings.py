"""turn_datasets.strings: the same results through numpy 2's StringDType and numpy 1.26's
np.char (both paths run in either environment; make test runs the suite on both numpys)."""

from __future__ import annotations

import numpy as np
import pytest

from turn_datasets import strings


@pytest.fixture(params=["string-dtype", "np-char"])
def path(request, monkeypatch):
    if request.param == "np-char":
        monkeypatch.setattr(strings, "HAS_STRING_DTYPE", False)
    elif not strings.HAS_STRING_DTYPE:
        pytest.skip("numpy < 2 has no StringDType (the np.char path is tested here)")
    return request.param


def test_strip_count_and_objects_agree_with_str_methods(path):
    cells = ["  a,b ", "\tP01\u3000", "", "x" * 500, " , ,,"]
    text = strings.text_array(cells)
    assert [str(v) for v in strings.strip(text)] == [c.strip() for c in cells]
    assert strings.count(text, ",").tolist() == [c.count(",") for c in cells]
    out = strings.stripped_objects(np.array(cells, dtype=object))
    assert out.dtype == object and out.tolist() == [c.strip() for c in cells]
    assert all(type(v) is str for v in out)
