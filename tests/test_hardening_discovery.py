"""Walking dataset folders: links, unreadable folders, subfolders, and files that must never
be unpickled (issue 10, #2, #3, #4, #12, #16)."""

from __future__ import annotations

import io
import json
import os
import pickle
import zipfile
from pathlib import Path

import numpy as np
import pytest
from _eaf_builder import Tier, write_eaf
from conftest import run_turn_datasets as _run
from conftest import run_turn_eval

from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.errors import TurnbenchError
from turn_datasets.mocap import readers
from turn_datasets.remap.eaf import expand_eaf_paths
from turn_datasets.synthetic import mocap as sm
from turn_datasets.synthetic.h36m_files import write_h36m_cdf, write_videopose_npz


def _positions(seed: int) -> np.ndarray:
    segs = [sm.Segment.stand(1.0), sm.Segment.walk(2.0, 1.2), sm.Segment.pivot_turn(90.0, 1.4)]
    segs += [sm.Segment.walk(2.0, 1.2), sm.Segment.stand(1.0)]
    return sm.generate_sequence(seed=seed, segments=segs, noise_mm=5.0).positions


def _subject(root: Path, subject: str, seed: int) -> Path:
    cdf = root / subject / "MyPoseFeatures" / "D3_Positions" / "Walking 1.cdf"
    cdf.parent.mkdir(parents=True)
    write_h36m_cdf(cdf, _positions(seed))
    return cdf


# -- #2 symbolic links to folders ----------------------------------------------------------


def test_a_subject_folder_that_is_a_symbolic_link_is_mined(tmp_path, capsys):
    elsewhere = tmp_path / "disk2"
    _subject(elsewhere, "S5", 1)
    root = tmp_path / "h36m"
    _subject(root, "S1", 2)
    (root / "S5").symlink_to(elsewhere / "S5", target_is_directory=True)
    found = [f.path for f in readers.discover([root])]
    assert [p.relative_to(root).parts[0] for p in found] == ["S1", "S5"]
    out = tmp_path / "o.csv"
    code, _, err = _run(["h36m", "mine", root, "--out", out], capsys)
    assert code == 0, err
    manifest = json.loads((tmp_path / "o.manifest.json").read_text())
    assert sorted(Path(i["path"]).parts[-4] for i in manifest["inputs"]) == ["S1", "S5"]


def test_a_root_of_only_linked_folders_is_not_called_empty(tmp_path):
    elsewhere = tmp_path / "disk2"
    _subject(elsewhere, "S5", 1)
    root = tmp_path / "h36m"
    root.mkdir()
    (root / "S5").symlink_to(elsewhere / "S5", target_is_directory=True)
    assert len(readers.discover([root])) == 1


def test_a_link_back_up_the_tree_does_not_loop(tmp_path):
    root = tmp_path / "h36m"
    _subject(root, "S1", 1)
    (root / "S1" / "again").symlink_to(root, target_is_directory=True)
    assert [f.path for f in readers.discover([root])] == [
        root / "S1" / "MyPoseFeatures" / "D3_Positions" / "Walking 1.cdf"
    ]


# -- #3 unreadable folders ---------------------------------------------------------------


@pytest.fixture()
def unreadable(monkeypatch):
    """Make a folder unreadable, as chmod 000 does for an ordinary user (root reads anything,
    so under root the refusal is simulated where os.walk asks the OS)."""

    def deny(folder: Path) -> None:
        if os.geteuid() != 0:
            folder.chmod(0)
            return
        real = os.scandir

        def scandir(path="."):
            if Path(path).resolve() == folder.resolve():
                raise PermissionError(13, "Permission denied", str(path))
            return real(path)

        monkeypatch.setattr(os, "scandir", scandir)

    yield deny


def test_an_unreadable_subject_folder_is_an_error_naming_it(tmp_path, capsys, unreadable):
    root = tmp_path / "h36m"
    _subject(root, "S1", 1)
    _subject(root, "S5", 2)
    unreadable(root / "S5")
    out = tmp_path / "o.csv"
    code, _, err = _run(["h36m", "mine", root, "--out", out], capsys)
    assert code == EXIT_BAD_INPUT and not out.exists()
    assert f"{root / 'S5'}: cannot read this folder: Permission denied" in err


def test_an_unreadable_folder_with_skip_bad_is_in_the_manifest(tmp_path, capsys, unreadable):
    root = tmp_path / "h36m"
    _subject(root, "S1", 1)
    _subject(root, "S5", 2)
    unreadable(root / "S5")
    out = tmp_path / "o.csv"
    code, _, err = _run(["h36m", "mine", root, "--out", out, "--skip-bad"], capsys)
    assert code == 0, err
    manifest = json.loads((tmp_path / "o.manifest.json").read_text())
    assert [s["path"] for s in manifest["skipped"]] == [str(root / "S5")]
    assert "cannot read this folder" in manifest["skipped"][0]["error"]


def test_remap_folder_walk_refuses_an_unreadable_subfolder(tmp_path, unreadable):
    (tmp_path / "eaf" / "day2").mkdir(parents=True)
    write_eaf(tmp_path / "eaf" / "s1.eaf", [Tier("Turn a", annotator="a", participant="P")])
    unreadable(tmp_path / "eaf" / "day2")
    with pytest.raises(TurnbenchError, match="cannot read this folder"):
        expand_eaf_paths(tmp_path / "eaf")


# -- #4 every folder walked, sorted, counted -----------------------------------------------


def test_remap_labels_reads_subfolders_sorted_and_says_how_many(tmp_path, capsys):
    eaf = tmp_path / "eaf"
    for sub, session, start in (("day2", "s2", 5000), ("day1", "s1", 1000), ("", "s0", 3000)):
        (eaf / sub).mkdir(parents=True, exist_ok=True)
        write_eaf(
            eaf / sub / f"{session}.eaf",
            [
                Tier(
                    "Turn a",
                    annotator="a",
                    participant="P1",
                    annotations=[(start, start + 900, "90")],
                )
            ],
        )
    (eaf / ".trash").mkdir()
    write_eaf(eaf / ".trash" / "old.eaf", [Tier("Turn a", annotator="a", participant="P1")])
    assert [p.relative_to(eaf).as_posix() for p in expand_eaf_paths(eaf)] == [
        "day1/s1.eaf",
        "day2/s2.eaf",
        "s0.eaf",
    ]
    parts = tmp_path / "p.csv"
    parts.write_text("subject,cohort,pair,sex,age,years_since_diagnosis\nP1,PD,a,F,60,4\n")
    out = tmp_path / "o" / "labels.csv"
    code, _, err = _run(["remap", "labels", eaf, "--participants", parts, "--out", out], capsys)
    assert code == 0, err
    assert "3 turns (0 double-annotated) from 3 annotations in 3 ELAN files" in err
    code, _, err = _run(["remap", "inspect", eaf], capsys)
    assert code == 0 and "read 3 ELAN files" in err


def test_mine_says_how_many_files_it_read(tmp_path, capsys):
    root = tmp_path / "h36m"
    _subject(root, "S1", 1)
    code, _, err = _run(["h36m", "mine", root, "--out", tmp_path / "o.csv"], capsys)
    assert code == 0, err
    assert "(1 file read)" in err


# -- #12 never unpickle what a walk finds ----------------------------------------------------


class _Payload:
    """Unpickling this creates a file: proof that code ran."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def _hostile_npz(path: Path, marker: Path) -> Path:
    obj = np.empty((), dtype=object)
    obj[()] = {"S1": {"Walking 1": _Payload(marker)}}
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, obj, allow_pickle=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("positions_3d.npy", buffer.getvalue())
    return path


def test_a_deep_npz_with_positions_3d_is_never_unpickled(tmp_path, capsys):
    marker = tmp_path / "PWNED"
    root = tmp_path / "h36m"
    _subject(root, "S1", 1)
    _hostile_npz(root / "some" / "deep" / "folder" / "cache.npz", marker)
    code, _, err = _run(["h36m", "mine", root, "--out", tmp_path / "o.csv"], capsys)
    assert code == 0, err
    assert not marker.exists()
    manifest = json.loads((tmp_path / "o.manifest.json").read_text())
    assert [Path(i["path"]).name for i in manifest["inputs"]] == ["Walking 1.cdf"]


@pytest.mark.parametrize("where", ["named", "root"])
def test_a_hostile_videopose_file_is_refused_before_its_pickle_runs(tmp_path, capsys, where):
    marker = tmp_path / "PWNED"
    root = tmp_path / "h36m"
    root.mkdir()
    npz = _hostile_npz(root / "data_3d_h36m.npz", marker)
    code, _, err = _run(
        ["h36m", "mine", npz if where == "named" else root, "--out", tmp_path / "o.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT
    assert not marker.exists()
    assert f"{npz}: refused: 'positions_3d' is a pickle that would run code" in err
    assert "posix.system" in err or "os.system" in err


def test_a_real_videopose_file_still_reads(tmp_path):
    npz = write_videopose_npz(
        tmp_path / "data_3d_h36m.npz", {"S11": {"Walking 1": _positions(3) / 1000}}
    )
    seqs = list(readers.read_source(readers.discover([npz])[0]))
    assert [(s.subject, s.action) for s in seqs] == [("S11", "Walking")]
    np.testing.assert_allclose(seqs[0].positions, (_positions(3) / 1000).astype(np.float32), atol=0)


def test_pickle_is_never_called_on_a_walked_generic_array(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(pickle, "load", lambda *a, **k: calls.append(a))
    root = tmp_path / "arrays"
    root.mkdir()
    np.savez(root / "x.npz", positions=np.zeros((4, 17, 3)))
    assert [f.fmt for f in readers.discover([root], fmt="array")] == ["array"]
    assert calls == []


# -- #16 messages that blame the right thing ------------------------------------------------


def test_a_text_file_named_npz_is_called_not_an_npz(tmp_path, capsys):
    bad = tmp_path / "poses.npz"
    bad.write_text("clip_id,angle\n")
    arrays = ["--layout", "h36m17", "--fps", "50", "--up-axis", "z", "--units", "m"]
    code, _, err = _run(
        ["h36m", "mine", bad, "--format", "array", *arrays, "--out", tmp_path / "o.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT
    assert "pickled" not in err and f"{bad}: cannot open this .npz: it is not an .npz" in err
    code, _, err = run_turn_eval(
        ["predict", bad, "--layout", "h36m17", "--out", tmp_path / "p.csv"], capsys
    )
    assert code == EXIT_BAD_INPUT
    assert "pickled" not in err and f"{bad}: cannot open this .npz: it is not an .npz" in err


def test_a_manifest_path_that_is_a_folder_is_named(tmp_path, capsys):
    root = tmp_path / "h36m"
    _subject(root, "S1", 1)
    (tmp_path / "q.manifest.json").mkdir()
    code, _, err = _run(["h36m", "mine", root, "--out", tmp_path / "q.csv"], capsys)
    assert code == EXIT_BAD_INPUT
    # refused before any mining, as any output path that is not a regular file
    assert f"{tmp_path / 'q.manifest.json'}: is a folder, not a regular file" in err
    assert not (tmp_path / "q.csv").exists()


def test_a_forced_format_reads_a_file_whatever_its_unknown_suffix(tmp_path):
    cdf = _subject(tmp_path, "S1", 1)
    dat = cdf.with_name("Walking 1.dat")  # an export that lost its suffix
    cdf.rename(dat)
    found = readers.discover([dat], fmt="cdf")
    assert [(f.path, f.fmt) for f in found] == [(dat, "cdf")]
    assert len(list(readers.read_source(found[0]))) == 1
