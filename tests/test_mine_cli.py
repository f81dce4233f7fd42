"""``turn-datasets h36m mine`` and ``h36m stats``: outputs, manifest, curation, bad input."""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import run_turn_datasets as run

from turn_datasets.cli.common import EXIT_BAD_INPUT
from turn_datasets.h36m.clip_index import CLIP_INDEX_DTYPES
from turn_datasets.h36m.miner import MinerParams
from turn_datasets.synthetic import mocap as sm
from turn_datasets.synthetic.h36m_files import write_h36m_cdf, write_h36m_h5, write_videopose_npz

REPO = Path(__file__).resolve().parents[1]


def _sequence(seed: int, turns: list[float], noise_mm: float = 10.0) -> sm.SyntheticSequence:
    segs: list[sm.Segment] = [sm.Segment.stand(1.0)]
    for angle in turns:
        segs += [sm.Segment.walk(2.0, 1.2), sm.Segment.pivot_turn(angle, 1.4)]
    segs += [sm.Segment.walk(2.0, 1.2), sm.Segment.stand(1.0)]
    return sm.generate_sequence(seed=seed, segments=segs, noise_mm=noise_mm)


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> dict:
    """A small Human3.6M tree (S1 as CDF, S9 as h5) and a VideoPose3D npz (S11)."""
    root = tmp_path_factory.mktemp("corpus")
    seqs = {
        ("S1", "Walking 1"): _sequence(1, [90.0, -135.0]),
        ("S9", "WalkDog"): _sequence(2, [180.0], noise_mm=0.0),  # clean: adjust is exact
        ("S11", "Walking 1"): _sequence(3, [-90.0]),
        ("S11", "Directions"): _sequence(4, [60.0, 100.0]),
    }
    tree = root / "h36m"
    cdf = tree / "S1" / "MyPoseFeatures" / "D3_Positions" / "Walking 1.cdf"
    cdf.parent.mkdir(parents=True)
    write_h36m_cdf(cdf, seqs[("S1", "Walking 1")].positions)
    h5 = tree / "S9" / "MyPoses" / "3D_positions" / "WalkDog.h5"
    h5.parent.mkdir(parents=True)
    write_h36m_h5(h5, seqs[("S9", "WalkDog")].positions)
    npz = root / "data_3d_h36m.npz"
    write_videopose_npz(
        npz,
        {"S11": {a: seqs[("S11", a)].positions / 1000.0 for a in ("Walking 1", "Directions")}},
    )
    return {"root": root, "tree": tree, "cdf": cdf, "h5": h5, "npz": npz, "seqs": seqs}


def _mine(corpus, out: Path, capsys, *extra) -> tuple[int, str, str]:
    return run(["h36m", "mine", corpus["tree"], corpus["npz"], "--out", out, *extra], capsys)


def test_mine_writes_the_index_and_its_manifest(corpus, tmp_path, capsys) -> None:
    out = tmp_path / "turn-h36m.csv"
    code, stdout, stderr = _mine(corpus, out, capsys)
    assert code == 0, stderr
    assert stdout == ""
    assert "mining sequences" in stderr  # the progress bar's label (stderr is not a tty)
    index = pd.read_csv(out, keep_default_na=False)
    assert list(index.columns) == list(CLIP_INDEX_DTYPES)
    # 6 planted turns, each found once, in order S1 < S9 < S11
    assert len(index) == 6
    assert index["subject"].tolist() == ["S1", "S1", "S9", "S11", "S11", "S11"]
    assert index["split"].tolist() == ["train", "train", "test", "test", "test", "test"]
    assert index["clip_id"].str.startswith(("S1_Walking-1_", "S9_WalkDog_", "S11_")).all()
    assert index["direction"].tolist() == ["left", "right", "left", "left", "left", "right"]
    expected_bins = 45 * np.floor(index["angle_deg"] / 45 + 0.5)
    assert index["bin_deg"].tolist() == expected_bins.astype(int).tolist()
    assert f"wrote 6 clips from 4 sequences to {out}" in stderr

    manifest = json.loads((tmp_path / "turn-h36m.manifest.json").read_text())
    assert manifest["parameters"]["miner"] == {
        k: float(v) for k, v in MinerParams().__dict__.items()
    }
    by_path = {i["path"]: i for i in manifest["inputs"]}
    for key, fmt, units in (
        ("cdf", "cdf", ["mm"]),
        ("h5", "h36m-h5", ["mm"]),
        ("npz", "videopose-npz", ["m"]),
    ):
        record = by_path[str(corpus[key])]
        assert record["sha256"] == hashlib.sha256(corpus[key].read_bytes()).hexdigest()
        assert record["format"] == fmt and record["units"] == units and record["status"] == "read"
        assert record["frame_offset"] == 0
    assert by_path[str(corpus["npz"])]["sequences"] == 2
    counts = manifest["counts"]
    assert counts["clips"] == 6 and counts["sequences"] == 4
    assert counts["frames"] == sum(s.n_frames for s in corpus["seqs"].values())
    assert counts["per_bin_deg"] == {
        str(b): int(n) for b, n in sorted(expected_bins.astype(int).value_counts().items())
    }
    assert counts["per_subject"] == {"S1": 2, "S9": 1, "S11": 3}
    assert manifest["skipped"] == [] and manifest["overrides"]["unmatched"] == []
    dt.datetime.fromisoformat(manifest["created_utc"])


def test_same_inputs_give_the_same_bytes(corpus, tmp_path, capsys) -> None:
    a, b = tmp_path / "a" / "index.csv", tmp_path / "b" / "index.csv"
    assert _mine(corpus, a, capsys)[0] == 0
    assert _mine(corpus, b, capsys)[0] == 0
    assert a.read_bytes() == b.read_bytes()
    # The manifests are the same bytes once the one line holding the timestamp is blanked
    # (DESIGN.md: "a manifest's timestamp aside"); the timestamp is the only difference.
    stamp = re.compile(rb'^  "created_utc": "[^"]+",$', re.MULTILINE)
    ma = (a.parent / "index.manifest.json").read_bytes()
    mb = (b.parent / "index.manifest.json").read_bytes()
    assert len(stamp.findall(ma)) == len(stamp.findall(mb)) == 1
    assert stamp.sub(b"", ma) == stamp.sub(b"", mb)


def test_generic_arrays_with_their_options(corpus, tmp_path, capsys) -> None:
    # S9's sequence as a y-up array in metres: the same clip as from its h5 (z up, mm).
    seq = corpus["seqs"][("S9", "WalkDog")]
    p = seq.positions / 1000.0
    y_up = np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)  # z up -> y up, by hand
    arr = tmp_path / "S9" / "walk.npy"
    arr.parent.mkdir()
    np.save(arr, y_up)
    out = tmp_path / "arrays.csv"
    code, _, stderr = run(
        [
            "h36m",
            "mine",
            arr,
            "--layout",
            "h36m32",
            "--fps",
            "50",
            "--up-axis",
            "y",
            "--units",
            "m",
            "--out",
            out,
        ],
        capsys,
    )
    assert code == 0, stderr
    from_h5 = tmp_path / "h5.csv"
    assert run(["h36m", "mine", corpus["h5"], "--out", from_h5], capsys)[0] == 0
    a, b = pd.read_csv(out), pd.read_csv(from_h5)
    cols = ["start_frame", "end_frame", "direction", "bin_deg"]
    pd.testing.assert_frame_equal(a[cols], b[cols])
    assert a["angle_deg"][0] == pytest.approx(b["angle_deg"][0], abs=1e-6)
    # without the options a generic array cannot be read: one line naming the file
    code, _, stderr = run(["h36m", "mine", arr, "--out", tmp_path / "x.csv"], capsys)
    assert code == EXIT_BAD_INPUT and str(arr) in stderr
    assert not (tmp_path / "x.csv").exists()


def test_format_forces_one_reader(corpus, tmp_path, capsys) -> None:
    # The tree holds S1 as CDF and S9 as 3d-pose-baseline h5: --format h36m-h5 takes S9 alone
    # (its one planted 180-degree turn).
    out = tmp_path / "h5-only.csv"
    code, _, stderr = run(
        ["h36m", "mine", corpus["tree"], "--format", "h36m-h5", "--out", out], capsys
    )
    assert code == 0, stderr
    index = pd.read_csv(out)
    assert index["subject"].tolist() == ["S9"] and index["source"].tolist() == [str(corpus["h5"])]
    # a named file whose suffix does not fit the forced format is listed as unreadable
    code, _, stderr = run(["h36m", "mine", corpus["npz"], "--format", "cdf", "--out", out], capsys)
    assert code == EXIT_BAD_INPUT
    assert f"turn-datasets: error: {corpus['npz']}: a cdf file should end in .cdf" in stderr


# --- curation ---------------------------------------------------------------------------


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def test_overrides_exclude_keep_adjust_and_unmatched(corpus, tmp_path, capsys) -> None:
    plain = tmp_path / "plain.csv"
    assert _mine(corpus, plain, capsys)[0] == 0
    ids = pd.read_csv(plain)["clip_id"].tolist()
    # S9's planted 180° turn, from the generator's truth; adjust the clip to exactly it.
    planted = corpus["seqs"][("S9", "WalkDog")].planted.iloc[0]
    s9 = [i for i in ids if i.startswith("S9_")][0]
    curation = _write(
        tmp_path / "curation.csv",
        "clip_id,decision,start_frame,end_frame,note\n"
        f"{ids[0]},exclude,,,not a turn\n"
        f"{ids[1]},keep,,,checked\n"
        f"{s9},adjust,{planted.start_frame},{planted.end_frame},tighter\n"
        "S1_Walking-1_1-2,exclude,,,stale\n",
    )
    out = tmp_path / "curated.csv"
    code, _, stderr = _mine(corpus, out, capsys, "--overrides", curation)
    assert code == 0, stderr
    assert f"override S1_Walking-1_1-2 (exclude, {curation}:5) matches no mined clip" in stderr
    index = pd.read_csv(out)
    assert ids[0] not in set(index.clip_id) and ids[1] in set(index.clip_id)
    new_id = f"S9_WalkDog_{planted.start_frame}-{planted.end_frame}"
    assert new_id in set(index.clip_id) and s9 not in set(index.clip_id)
    adjusted = index.set_index("clip_id").loc[new_id]
    # noise-free hips: the re-measured hip rotation is the planted one over those frames
    # (issue 11: this was angle_deg, which is now the heading change), and the angle is the
    # heading change planted, to the generator's postural wander (0.5° s.d.)
    assert adjusted.hip_rotation_deg == pytest.approx(abs(planted.angle_deg), abs=0.5)
    assert adjusted.angle_deg == pytest.approx(abs(planted.heading_deg), abs=1.5)
    assert adjusted.duration_s == pytest.approx(planted.duration_s)
    assert len(index) == 5
    manifest = json.loads((tmp_path / "curated.manifest.json").read_text())
    ov = manifest["overrides"]
    assert ov["file"] == str(curation)
    assert ov["sha256"] == hashlib.sha256(curation.read_bytes()).hexdigest()
    assert [(a["clip_id"], a["decision"], a["result_clip_id"]) for a in ov["applied"]] == [
        (ids[0], "exclude", None),
        (ids[1], "keep", ids[1]),
        (s9, "adjust", new_id),
    ]
    assert [(u["clip_id"], u["line"]) for u in ov["unmatched"]] == [("S1_Walking-1_1-2", 5)]


@pytest.mark.parametrize(
    ("body", "line", "message"),
    [
        ("a,remove,,,\n", 2, "decision 'remove' is not one of exclude, keep, adjust"),
        ("a,exclude,,,\nb,adjust,10,,\n", 3, "adjust needs start_frame and end_frame"),
        ("a,adjust,10,5,\n", 2, "must exceed start_frame"),
        ("a,adjust,1.5,9,\n", 2, "not a whole number"),
        ("a,exclude,3,9,\n", 2, "exclude takes no frames"),
        (",keep,,,\n", 2, "empty clip_id"),
        ("a,keep,,,\na,exclude,,,\n", 3, "already has an override on line 2"),
        ("a,keep,,\n", 2, "row has 4 fields but the header has 5"),
    ],
)
def test_bad_override_rows_name_file_and_line(corpus, tmp_path, capsys, body, line, message):
    curation = _write(
        tmp_path / "curation.csv", "clip_id,decision,start_frame,end_frame,note\n" + body
    )
    out = tmp_path / "index.csv"
    code, _, stderr = _mine(corpus, out, capsys, "--overrides", curation)
    assert code == EXIT_BAD_INPUT
    assert stderr.startswith(f"turn-datasets: error: {curation}:{line}: ")
    assert message in stderr
    assert len(stderr.strip().splitlines()) == 1
    assert not out.exists() and not (tmp_path / "index.manifest.json").exists()


def test_override_header_and_adjust_outside_the_sequence(corpus, tmp_path, capsys) -> None:
    bad_header = _write(tmp_path / "h.csv", "clip_id,decision\nx,keep\n")
    code, _, stderr = _mine(corpus, tmp_path / "i.csv", capsys, "--overrides", bad_header)
    assert (
        code == EXIT_BAD_INPUT
        and (f"{bad_header}:1: the overrides file lacks columns 'start_frame', 'end_frame', 'note'")
        in stderr
    )
    plain = tmp_path / "plain.csv"
    _mine(corpus, plain, capsys)
    first = pd.read_csv(plain)["clip_id"][0]
    far = _write(
        tmp_path / "far.csv",
        f"clip_id,decision,start_frame,end_frame,note\n{first},adjust,100,99999,\n",
    )
    out = tmp_path / "far-index.csv"
    code, _, stderr = _mine(corpus, out, capsys, "--overrides", far)
    assert code == EXIT_BAD_INPUT and f"{far}:2: cannot adjust {first}" in stderr
    assert not out.exists()


def test_a_semicolon_overrides_export_is_applied_and_said(corpus, tmp_path, capsys) -> None:
    plain = tmp_path / "plain.csv"
    assert _mine(corpus, plain, capsys)[0] == 0
    first = pd.read_csv(plain)["clip_id"][0]
    curation = tmp_path / "curation.csv"
    curation.write_bytes(
        b"\xef\xbb\xbfclip_id;decision;start_frame;end_frame;note\r\n"
        + f"{first};exclude;;;not a turn\r\n".encode()
    )
    out = tmp_path / "curated.csv"
    code, _, stderr = _mine(corpus, out, capsys, "--overrides", curation)
    assert code == 0, stderr
    assert f"warning: {curation}: read as semicolon-separated (a spreadsheet export?)" in stderr
    assert first not in set(pd.read_csv(out)["clip_id"])
    assert len(pd.read_csv(out)) == len(pd.read_csv(plain)) - 1


def test_adjusting_a_clip_onto_another_is_refused(corpus, tmp_path, capsys) -> None:
    plain = tmp_path / "plain.csv"
    assert _mine(corpus, plain, capsys)[0] == 0
    first, second = pd.read_csv(plain)["clip_id"][:2]  # S1's two turns
    start, end = first.rsplit("_", 1)[1].split("-")
    curation = _write(
        tmp_path / "curation.csv",
        f"clip_id,decision,start_frame,end_frame,note\n{second},adjust,{start},{end},\n",
    )
    out = tmp_path / "index.csv"
    code, _, stderr = _mine(corpus, out, capsys, "--overrides", curation)
    assert code == EXIT_BAD_INPUT
    assert stderr.strip().splitlines()[-1:] == [  # after the progress bar's label
        f"turn-datasets: error: {curation}:2: adjusting {second} to frames {start}-{end} makes "
        "it the same clip as another one of its sequence; exclude one of them instead"
    ]
    assert not out.exists()


# --- bad input --------------------------------------------------------------------------


@pytest.fixture()
def tree_with_bad_files(corpus, tmp_path) -> dict:
    tree = tmp_path / "h36m"
    shutil.copytree(corpus["tree"], tree)
    bad_cdf = tree / "S5" / "MyPoseFeatures" / "D3_Positions" / "Walking.cdf"
    bad_cdf.parent.mkdir(parents=True)
    bad_cdf.write_bytes(b"\x00not a cdf at all" * 10)
    good_h5 = tree / "S9" / "MyPoses" / "3D_positions" / "WalkDog.h5"
    truncated = tree / "S9" / "MyPoses" / "3D_positions" / "Walking.h5"
    truncated.write_bytes(good_h5.read_bytes()[:2000])
    return {"tree": tree, "bad": [bad_cdf, truncated]}


def test_unreadable_files_are_all_listed_then_nothing_is_written(
    tree_with_bad_files, tmp_path, capsys
):
    out = tmp_path / "index.csv"
    code, stdout, stderr = run(["h36m", "mine", tree_with_bad_files["tree"], "--out", out], capsys)
    assert code == EXIT_BAD_INPUT and stdout == ""
    lines = [ln for ln in stderr.splitlines() if ln.startswith("turn-datasets: error:")]
    assert len(lines) == 3  # one per bad file, then the verdict
    for bad, line in zip(tree_with_bad_files["bad"], lines, strict=False):
        assert line.startswith(f"turn-datasets: error: {bad}: ")
    assert "2 of 4 files could not be read; nothing written" in lines[-1]
    assert "Traceback" not in stderr
    assert not out.exists() and not (tmp_path / "index.manifest.json").exists()
    assert not list(tmp_path.glob(".index*"))  # no temporary file left behind


def test_skip_bad_writes_the_index_and_records_the_skipped_files(
    tree_with_bad_files, tmp_path, capsys
):
    out = tmp_path / "index.csv"
    code, _, stderr = run(
        ["h36m", "mine", tree_with_bad_files["tree"], "--out", out, "--skip-bad"], capsys
    )
    assert code == 0, stderr
    assert "skipped 2 unreadable file(s)" in stderr
    index = pd.read_csv(out)
    assert set(index.subject) == {"S1", "S9"} and len(index) == 3
    manifest = json.loads((tmp_path / "index.manifest.json").read_text())
    assert [(s["path"], s["item"]) for s in manifest["skipped"]] == [
        (str(p), None) for p in tree_with_bad_files["bad"]
    ]
    assert all(s["error"].startswith(s["path"]) for s in manifest["skipped"])
    statuses = {Path(i["path"]).name: i["status"] for i in manifest["inputs"]}
    assert statuses == {
        "Walking 1.cdf": "read",
        "Walking.cdf": "skipped",
        "WalkDog.h5": "read",
        "Walking.h5": "skipped",
    }


def test_a_corrupt_file_named_directly_is_listed_or_skipped(corpus, tmp_path, capsys) -> None:
    broken = tmp_path / "broken.npz"
    broken.write_bytes(corpus["npz"].read_bytes()[:5000])  # truncated: not even a zip
    out = tmp_path / "index.csv"
    code, _, stderr = run(["h36m", "mine", corpus["npz"], broken, "--out", out], capsys)
    assert code == EXIT_BAD_INPUT
    assert f"turn-datasets: error: {broken}: " in stderr and "1 of 2 files" in stderr
    assert not out.exists()
    code, _, stderr = run(
        ["h36m", "mine", corpus["npz"], broken, "--out", out, "--skip-bad"], capsys
    )
    assert code == 0, stderr
    assert set(pd.read_csv(out).subject) == {"S11"}
    manifest = json.loads((tmp_path / "index.manifest.json").read_text())
    assert [s["path"] for s in manifest["skipped"]] == [str(broken)]


def test_one_bad_sequence_in_a_file_of_many_is_listed_or_skipped_alone(tmp_path, capsys):
    # VideoPose3D's npz holds the whole dataset: one unusable sequence must not cost the rest
    turn = _sequence(5, [90.0]).positions / 1000.0
    no_hip = turn.copy()
    no_hip[:, 6] = np.nan  # the left hip, in every frame
    npz = tmp_path / "data_3d_h36m.npz"
    write_videopose_npz(npz, {"S1": {"Walking": turn, "Waiting": no_hip, "Jogging": turn}})
    out = tmp_path / "index.csv"
    code, stdout, stderr = run(["h36m", "mine", npz, "--out", out], capsys)
    assert code == EXIT_BAD_INPUT and stdout == ""
    lines = [ln for ln in stderr.splitlines() if ln.startswith("turn-datasets: error:")]
    assert lines[0].startswith(f"turn-datasets: error: {npz}, S1/Jogging: 'Jogging' is not a")
    assert lines[1] == (
        f"turn-datasets: error: {npz}, S1/Waiting: the left or right hip is NaN in every frame"
    )
    assert lines[2].startswith("turn-datasets: error: 2 sequence(s) could not be used; nothing")
    assert len(lines) == 3 and not out.exists()
    code, _, stderr = run(["h36m", "mine", npz, "--out", out, "--skip-bad"], capsys)
    assert code == 0, stderr
    assert "skipped 2 unusable sequence(s)" in stderr
    index = pd.read_csv(out)
    assert index[["subject", "action", "direction"]].values.tolist() == [["S1", "Walking", "left"]]
    manifest = json.loads((tmp_path / "index.manifest.json").read_text())
    assert [(s["path"], s["item"]) for s in manifest["skipped"]] == [
        (str(npz), "S1/Jogging"),
        (str(npz), "S1/Waiting"),
    ]
    (record,) = manifest["inputs"]
    assert (record["status"], record["sequences"], record["skipped_sequences"]) == ("read", 1, 2)
    assert manifest["counts"]["sequences"] == 1


def test_never_writes_over_an_input(corpus, tmp_path, capsys) -> None:
    npz = tmp_path / "data_3d_h36m.npz"
    shutil.copy(corpus["npz"], npz)
    before = npz.read_bytes()
    code, _, stderr = run(["h36m", "mine", npz, "--out", npz], capsys)
    assert code == EXIT_BAD_INPUT and "overwrite this input" in stderr
    assert npz.read_bytes() == before


def test_out_under_a_file_exits_2_before_mining(corpus, tmp_path, capsys) -> None:
    in_the_way = _write(tmp_path / "notes", "a file where a folder should be")
    code, stdout, stderr = _mine(corpus, in_the_way / "sub" / "index.csv", capsys)
    assert code == EXIT_BAD_INPUT and stdout == ""
    assert stderr.strip().splitlines() == [
        f"turn-datasets: error: {in_the_way}: is a file, so --out cannot be written under it"
    ]


def test_a_failed_write_leaves_neither_file(corpus, tmp_path, capsys, monkeypatch) -> None:
    # The disk fills up while the index is written: one line naming the file, exit 2, and
    # neither the index, nor the manifest, nor a temporary file is left.
    def full_disk(self, path, *args, **kwargs):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(pd.DataFrame, "to_csv", full_disk)
    out = tmp_path / "out" / "index.csv"
    code, _, stderr = _mine(corpus, out, capsys)
    assert code == EXIT_BAD_INPUT
    assert "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1] == (
        f"turn-datasets: error: {out}: cannot write the clip index: No space left on device"
    )
    assert list(out.parent.iterdir()) == []


def test_missing_source_exits_2_in_one_line_without_traceback(tmp_path) -> None:
    proc = subprocess.run(
        [
            str(Path(sys.executable).parent / "turn-datasets"),
            "h36m",
            "mine",
            str(tmp_path / "nowhere"),
            "--out",
            str(tmp_path / "i.csv"),
        ],
        capture_output=True,
        text=True,
        cwd=REPO,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.strip().splitlines() == [
        f"turn-datasets: error: {tmp_path / 'nowhere'}: no such file or folder"
    ]


def test_bad_miner_parameter_exits_2(corpus, tmp_path, capsys) -> None:
    code, _, stderr = _mine(corpus, tmp_path / "i.csv", capsys, "--stop-speed-deg-s", "30")
    assert code == EXIT_BAD_INPUT and "stop_speed_deg_s (30.0) must not exceed" in stderr


# --- stats ------------------------------------------------------------------------------

HAND_INDEX = """clip_id,subject,action,subaction,split,start_frame,end_frame,n_frames,fps,start_s,end_s,duration_s,angle_deg,direction,bin_deg,speed_deg_s,source
S1_Walking_0-50,S1,Walking,,train,0,50,50,50.0,0.0,1.0,1.0,50.0,left,45,50.0,a
S1_Walking_100-200,S1,Walking,,train,100,200,100,50.0,2.0,4.0,2.0,60.0,right,45,30.0,a
S9_Walking_0-100,S9,Walking,,test,0,100,100,50.0,0.0,2.0,2.0,80.0,left,90,40.0,b
S9_WalkDog_0-150,S9,WalkDog,,test,0,150,150,50.0,0.0,3.0,3.0,100.0,left,90,33.3,b
S11_WalkDog_0-50,S11,WalkDog,,test,0,50,50,50.0,0.0,1.0,1.0,110.0,right,90,110.0,c
S11_Walking_0-200,S11,Walking,,test,0,200,200,50.0,0.0,4.0,4.0,200.0,left,180,50.0,c
"""
# Bins by hand, 45 * floor(angle / 45 + 0.5): 50, 60 -> 45; 80, 100, 110 -> 90; 200 -> 180.
# bin 45: 2 clips, 50-60, mean 55.0, duration (1+2)/2 = 1.50 s;
# bin 90: 3 clips, 80-110, mean 290/3 = 96.67, duration (2+3+1)/3 = 2.00 s;
# bin 180: 1 clip, 200, duration 4.00 s;
# Total: 6 clips, 50-200, mean 600/6 = 100.0, duration 13/6 = 2.1667 s.
# Subjects: S1 2 (mean 55.0), S9 2 (mean 90.0), S11 2 (mean 155.0), S9 before S11.
# Actions: WalkDog 2 (100, 110: mean 105.0), Walking 4 (50, 60, 80, 200: mean 97.5).


def test_stats_markdown_is_table_3_by_hand(tmp_path, capsys) -> None:
    index = _write(tmp_path / "index.csv", HAND_INDEX)
    code, stdout, stderr = run(["h36m", "stats", index], capsys)
    assert code == 0, stderr
    lines = stdout.splitlines()
    assert "| 45 | 2 | 50.0 | 60.0 | 55.0 | 1.50 |" in lines
    assert "| 90 | 3 | 80.0 | 110.0 | 96.7 | 2.00 |" in lines
    assert "| 180 | 1 | 200.0 | 200.0 | 200.0 | 4.00 |" in lines
    assert "| **Total** | 6 | 50.0 | 200.0 | 100.0 | 2.17 |" in lines
    subjects = [ln.split(" | ")[0].strip("| ") for ln in lines if re.match(r"\| S\d", ln)]
    assert subjects == ["S1", "S9", "S11"]
    assert "| WalkDog | 2 | 100.0 | 110.0 | 105.0 | 2.00 |" in lines
    assert "| Walking | 4 | 50.0 | 200.0 | 97.5 | 2.25 |" in lines


def test_stats_csv_and_json(tmp_path, capsys) -> None:
    index = _write(tmp_path / "index.csv", HAND_INDEX)
    code, stdout, _ = run(["h36m", "stats", index, "--csv"], capsys)
    assert code == 0
    (tmp_path / "s.csv").write_text(stdout)
    table = pd.read_csv(tmp_path / "s.csv", dtype={"group": str})
    assert list(table.columns) == [
        "table",
        "group",
        "clips",
        "min_deg",
        "max_deg",
        "mean_deg",
        "mean_duration_s",
    ]
    total = table[(table.table == "bin") & (table.group == "Total")].iloc[0]
    assert total.clips == 6 and total.mean_deg == pytest.approx(600 / 6)
    assert total.mean_duration_s == pytest.approx(13 / 6)
    assert table[table.table == "bin"].group.tolist() == ["45", "90", "180", "Total"]
    code, stdout, _ = run(["h36m", "stats", index, "--format", "json"], capsys)
    doc = json.loads(stdout)
    assert doc["table3"]["90"] == {
        "clips": 3,
        "min_deg": 80.0,
        "max_deg": 110.0,
        "mean_deg": pytest.approx(290 / 3),
        "mean_duration_s": 2.0,
    }
    assert doc["subject"]["S11"]["mean_deg"] == 155.0


# The same index with the hip rotation (issue 11) appended: 55, 70, 85, 95, 118, 206.
HIP_VALUES = ("55.0", "70.0", "85.0", "95.0", "118.0", "206.0")
# By hand: hip bins 55 -> 45; 70, 85, 95 -> 90; 118 -> 135; 206 -> 225.
# bin 45: 1 clip, 55, 1.00 s; bin 90: 3 clips, 70-95, mean 250/3 = 83.3, (2+2+3)/3 = 2.33 s;
# bin 135: 1 clip, 118, 1.00 s; bin 225: 1 clip, 206, 4.00 s;
# Total: 6, 55-206, mean 629/6 = 104.8, 2.17 s.
# hip - angle: 5, 10, 5, -5, 8, 6; sorted -5, 5, 5, 6, 8, 10: median 5.5, quartiles (linear,
# positions 1.25 and 3.75) 5.0 and 6 + 0.75 * 2 = 7.5.


def _hand_index_with_hip() -> str:
    lines = HAND_INDEX.strip().splitlines()
    head = lines[0].replace(",source", ",hip_rotation_deg,source")
    rows = [
        ",".join(r.split(",")[:-1] + [h, r.split(",")[-1]])
        for r, h in zip(lines[1:], HIP_VALUES, strict=True)
    ]
    return "\n".join([head, *rows]) + "\n"


def test_stats_print_both_columns_by_hand(tmp_path, capsys) -> None:
    index = _write(tmp_path / "index.csv", _hand_index_with_hip())
    code, stdout, stderr = run(["h36m", "stats", index], capsys)
    assert code == 0, stderr
    lines = stdout.splitlines()
    # Table 3 by angle_deg is unchanged
    assert "| 90 | 3 | 80.0 | 110.0 | 96.7 | 2.00 |" in lines
    hip = lines[lines.index("## Table 3 by the hip rotation (hip_rotation_deg, binned by it)") :]
    for row in (
        "| 45 | 1 | 55.0 | 55.0 | 55.0 | 1.00 |",
        "| 90 | 3 | 70.0 | 95.0 | 83.3 | 2.33 |",
        "| 135 | 1 | 118.0 | 118.0 | 118.0 | 1.00 |",
        "| 225 | 1 | 206.0 | 206.0 | 206.0 | 4.00 |",
        "| **Total** | 6 | 55.0 | 206.0 | 104.8 | 2.17 |",
    ):
        assert row in hip, row
    assert "median 5.5°, interquartile 5.0° to 7.5°" in stdout
    code, stdout, _ = run(["h36m", "stats", index, "--format", "json"], capsys)
    doc = json.loads(stdout)
    assert doc["hip_minus_angle"] == {"median_deg": 5.5, "q25_deg": 5.0, "q75_deg": 7.5}
    assert doc["table3_hip_rotation"]["90"]["mean_deg"] == pytest.approx(250 / 3)
    code, stdout, _ = run(["h36m", "stats", index, "--csv"], capsys)
    (tmp_path / "s.csv").write_text(stdout)
    table = pd.read_csv(tmp_path / "s.csv", dtype={"group": str})
    assert table[table.table == "hip_rotation_bin"].group.tolist() == [
        "45",
        "90",
        "135",
        "225",
        "Total",
    ]
    # a negative hip rotation is refused with its line, like a negative angle
    bad = _write(tmp_path / "bad.csv", _hand_index_with_hip().replace(",85.0,", ",-85.0,"))
    code, _, stderr = run(["h36m", "stats", bad], capsys)
    assert code == EXIT_BAD_INPUT
    assert f"{bad}:4: hip_rotation_deg -85 is negative" in stderr


def test_stats_refuses_a_bad_index(tmp_path, capsys) -> None:
    bad = _write(
        tmp_path / "bad.csv", HAND_INDEX.replace(",100.0,left,90,33.3", ",abc,left,90,33.3")
    )
    code, _, stderr = run(["h36m", "stats", bad], capsys)
    assert code == EXIT_BAD_INPUT
    assert (
        stderr.strip() == f"turn-datasets: error: {bad}:5: angle_deg 'abc' is not a finite number"
    )
    # a bin that is not the angle's nearest multiple of 45 (80 -> 90, not 135), a negative
    # angle, a zero duration: each names its line
    for old, new, line, message in (
        (",80.0,left,90,", ",80.0,left,135,", 4, "bin_deg 135 is not the nearest multiple"),
        (",60.0,right,45,", ",-60.0,right,45,", 3, "angle_deg -60 is negative"),
        (",4.0,200.0,left", ",0.0,200.0,left", 7, "duration_s 0 is not positive"),
    ):
        bad = _write(tmp_path / "bad.csv", HAND_INDEX.replace(old, new))
        code, _, stderr = run(["h36m", "stats", bad], capsys)
        assert code == EXIT_BAD_INPUT
        assert stderr.strip().startswith(f"turn-datasets: error: {bad}:{line}: {message}")
    not_index = _write(tmp_path / "other.csv", "a,b\n1,2\n")
    code, _, stderr = run(["h36m", "stats", not_index], capsys)
    assert (
        code == EXIT_BAD_INPUT
        and f"{not_index}:1: the clip index lacks columns 'subject', 'action'" in stderr
    )


def test_stats_on_the_mined_index(corpus, tmp_path, capsys) -> None:
    out = tmp_path / "index.csv"
    assert _mine(corpus, out, capsys)[0] == 0
    code, stdout, _ = run(["h36m", "stats", out, "--csv"], capsys)
    assert code == 0
    (tmp_path / "s.csv").write_text(stdout)
    table = pd.read_csv(tmp_path / "s.csv", dtype={"group": str})
    assert table[(table.table == "bin") & (table.group == "Total")].clips.iloc[0] == 6


def test_every_miner_parameter_is_an_option_with_its_default_unit_and_sentence(capsys) -> None:
    # issue 3: "Every parameter has a default, a unit in its name, and a sentence in --help"
    import dataclasses

    from turn_datasets.cli.mine import mine_cmd

    options = {o.name: o for o in mine_cmd.params}
    for field in dataclasses.fields(MinerParams):
        option = options[field.name]
        assert f"--{field.name.replace('_', '-')}" in option.opts
        assert option.default == field.default and option.show_default
        assert field.name.endswith(("_deg", "_s", "_hz", "_deg_s")), field.name
        assert option.help and option.help.endswith("."), field.name
    code, stdout, _ = run(["h36m", "mine", "--help"], capsys)
    assert code == 0
    flat = " ".join(stdout.split())  # click wraps the help text
    # (issue 11: a clip's angle is now its heading change)
    assert "--min-turn-deg FLOAT Smallest heading change of a clip, in degrees" in flat
    assert "[default: 45.0]" in flat


@pytest.mark.parametrize("command", ["mine", "stats"])
def test_help_has_an_example(command, capsys) -> None:
    code, stdout, _ = run(["h36m", command, "--help"], capsys)
    assert code == 0 and "Example:" in stdout


def test_cmu_captures_mined_with_no_option_find_exactly_the_described_turns(cmu_dir, tmp_path):
    """A curator runs the command on the real CMU files as they are: the conversion's T-pose
    (frame 0) is recognised, so the straight walk 69_01 gives no false clip, and each
    described 90-degree turn is one clip in its direction (DESCRIPTIONS.txt)."""
    from turn_datasets.cli import main

    out = tmp_path / "cmu.csv"
    files = [str(cmu_dir / f"{n}.bvh") for n in ("16_18", "16_21", "69_01", "69_20", "69_25")]
    with pytest.raises(SystemExit) as exit_info:
        main(["h36m", "mine", *files, "--out", str(out)])
    assert exit_info.value.code == 0
    index = pd.read_csv(out)
    assert sorted(zip(index["action"], index["direction"], strict=True)) == [
        ("16_18", "left"),
        ("69_20", "right"),
        ("69_25", "left"),
    ]
    assert index["angle_deg"].between(85.0, 115.0).all()
    # the manifest says frame 0 was dropped from each file: index frame k is file frame k + 1
    manifest = json.loads((tmp_path / "cmu.manifest.json").read_text())
    assert [i["frame_offset"] for i in manifest["inputs"]] == [1] * 5
    # SOURCE.md: 69_25 has 464 frames in the file, so 463 were mined
    assert [i["frames"] for i in manifest["inputs"] if i["path"].endswith("69_25.bvh")] == [463]
    # Keeping the T-pose made a false 50° clip before issue 11; the heading change, measured
    # as a mean over a stride on each side, no longer turns one frame's jump into a turn
    kept = tmp_path / "kept.csv"
    with pytest.raises(SystemExit):
        main(["h36m", "mine", str(cmu_dir / "69_01.bvh"), "--keep-first-frame", "--out", str(kept)])
    assert len(pd.read_csv(kept)) == 0
    manifest = json.loads((tmp_path / "kept.manifest.json").read_text())
    assert [i["frame_offset"] for i in manifest["inputs"]] == [0]


def test_the_readmes_miner_defaults_are_the_options_defaults(capsys) -> None:
    """The README's "Defaults:" line of the miner's rule names every rule option of ``h36m
    mine`` with its default, and no other."""
    from dataclasses import fields

    text = " ".join((REPO / "README.md").read_text(encoding="utf-8").split())
    line = text.split("Defaults: ", 1)[1].split(". ", 1)[0]
    said = dict(re.findall(r"`--([a-z-]+) ([0-9.]+)`", line))
    prm = MinerParams()
    want = {f.name.replace("_", "-"): f"{getattr(prm, f.name):g}" for f in fields(prm)}
    assert said == want
    code, out, err = run(["h36m", "mine", "--help"], capsys)
    assert code == 0, err
    for name in want:
        assert f"--{name} " in out, name
