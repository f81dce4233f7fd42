"""The small checks every reader shares: one message for missing columns, one policy for a
bad sequence of a multi-sequence file, one wording for a file a library cannot parse."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from turn_datasets.errors import TurnbenchError, require_columns
from turn_datasets.mocap.checks import check_joint_count, skip_bad, unreadable
from turn_datasets.skeleton import get_layout


def test_require_columns_names_what_is_missing_and_what_is_there() -> None:
    require_columns(["a", "b", "c"], ["c", "a"], what="the table")  # all there: no error
    with pytest.raises(TurnbenchError) as one:
        require_columns(["a", "b"], ["a", "z"], what="the table", file="t.csv")
    assert str(one.value) == "t.csv:1: the table lacks column 'z'; its header has 'a', 'b'"
    with pytest.raises(TurnbenchError) as two:
        require_columns(("x",), ("y", "z"), what="it", file="t.csv", row=3, note=" (note)")
    assert str(two.value) == "t.csv:3: it lacks columns 'y', 'z'; its header has 'x' (note)"


def _half(x: int) -> int:
    if x % 2:
        raise TurnbenchError(f"{x} is odd", item=str(x))
    return x // 2


def test_skip_bad_reports_or_raises() -> None:
    bad: list[str] = []
    assert list(skip_bad([2, 3, 4, 5], _half, lambda e: bad.append(str(e)))) == [1, 2]
    assert bad == ["3: 3 is odd", "5: 5 is odd"]
    seen = skip_bad([2, 3, 4], _half, None)
    assert next(seen) == 1
    with pytest.raises(TurnbenchError, match="3 is odd"):
        next(seen)


def test_unreadable_names_the_file_and_lets_our_own_errors_pass() -> None:
    with pytest.raises(TurnbenchError) as err:
        with unreadable("this array", Path("a.npz"), item="k", guess="pickled?"):
            raise KeyError("zlib")
    assert str(err.value) == "a.npz, k: cannot read this array (pickled?): 'zlib'"
    with pytest.raises(TurnbenchError) as ours:
        with unreadable("HDF5", Path("a.h5")):
            raise TurnbenchError("no dataset 'x'", file="a.h5")
    assert str(ours.value) == "a.h5: no dataset 'x'"  # not reworded as an unreadable file


def test_check_joint_count() -> None:
    layout = get_layout("h36m17")
    ok = np.zeros((4, 17, 3))
    assert check_joint_count(ok, layout, path=Path("a.npy"), item=None) is ok
    with pytest.raises(TurnbenchError) as err:
        check_joint_count(np.zeros((4, 16, 3)), layout, path=Path("a.npz"), item="b")
    assert "a.npz, b: array has 16 joints but layout 'h36m17' has 17 (shape (4, 16, 3))" in str(
        err.value
    )
    assert err.value.hint == "choose the layout with --layout"


def test_skeleton_source_needs_what_generic_arrays_do_not_say() -> None:
    from turn_eval.cli.common import SkeletonSource

    # the layout must be given; the vertical axis of generic arrays is inferred unless given
    with pytest.raises(TurnbenchError, match=r"^generic arrays need --layout \(hint"):
        SkeletonSource("arrays", None, None).layout()
    assert SkeletonSource("arrays", "h36m32", None).layout().n_joints == 32
    assert SkeletonSource("arrays", "h36m32", None).up_axis_option == "auto"
    assert SkeletonSource("arrays", "h36m32", "-y").up_axis_option == "-y"
    with pytest.raises(TurnbenchError, match="--from motionbert files are in the h36m17"):
        SkeletonSource("motionbert", "h36m32", None).layout()
    assert SkeletonSource("motionbert", None, None).layout().name == "h36m17"
    # a named format's own axis (None here) unless one is given
    assert SkeletonSource("motionbert", None, None).up_axis_option is None
    assert SkeletonSource("motionbert", None, "auto").up_axis_option == "auto"
