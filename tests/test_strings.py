"""turn_datasets.strings: the same results through numpy 2's StringDType and the numpy 1.26
fallback (both paths run in either environment; make test runs the suite on both numpys)."""

from __future__ import annotations

import numpy as np
import pytest

from turn_datasets import strings


@pytest.fixture(params=["string-dtype", "python-str"])
def path(request, monkeypatch):
    if request.param == "python-str":
        monkeypatch.setattr(strings, "HAS_STRING_DTYPE", False)
    elif not strings.HAS_STRING_DTYPE:
        pytest.skip("numpy < 2 has no StringDType (the fallback is tested here)")
    return request.param


def test_strip_count_and_objects_agree_with_str_methods(path):
    cells = ["  a,b ", "\tP01\u3000", "", "x" * 500, " , ,,", "\x00", "a\x00,"]
    text = strings.text_array(cells)
    assert [str(v) for v in text] == cells  # a trailing NUL is text, not padding
    if path == "python-str":  # numpy 2's own functions drop a trailing NUL; the callers know
        assert [str(v) for v in strings.strip(text)] == [c.strip() for c in cells]
    assert [str(v) for v in strings.strip(text[:5])] == [c.strip() for c in cells[:5]]
    assert strings.count(text, ",").tolist() == [c.count(",") for c in cells]
    out = strings.stripped_objects(np.array(cells[:5], dtype=object))
    assert out.dtype == object and out.tolist() == [c.strip() for c in cells[:5]]
    assert all(type(v) is str for v in out)
