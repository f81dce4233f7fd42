"""Mining a whole corpus: the use case behind ``turn-datasets h36m mine``.

Every source file is read one sequence at a time (:func:`turn_datasets.mocap.readers.read_source`),
each sequence mined (:func:`turn_datasets.h36m.miner.mine_clips`) and curated
(:func:`turn_datasets.h36m.overrides.apply_overrides`); the clips of all make one index
(:func:`turn_datasets.h36m.miner.build_index`) and the record of how it was made its manifest
(:mod:`turn_datasets.h36m.manifest`).

The corpus policy for bad input: a file that cannot be read, or one unusable sequence in a
file of many (VideoPose3D's npz holds all of Human3.6M), fails the run after every problem is
reported, unless ``skip_bad``: then the index is made without them and the manifest lists
them (``skipped``: whole files first, ``item`` null; then single sequences). A curation error
(an adjustment outside its sequence) always fails: it is the curator's, not the file's.

The command line, the notebooks and the coming detector call :func:`find_sources`,
:func:`mine_corpus` and :func:`write_corpus`; the command only parses options and prints.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from turn_datasets.errors import TurnbenchError
from turn_datasets.fileio import atomic_path, sha256_file, to_json_text
from turn_datasets.h36m.manifest import build_manifest, manifest_path
from turn_datasets.h36m.miner import (
    FILTER_MAX_FRACTION_OF_FPS,
    FILTER_MIN_FRACTION_OF_FPS,
    MinerParams,
    SequenceClips,
    build_index,
    mine_clips,
    position_filter_applies,
)
from turn_datasets.h36m.overrides import Overrides, apply_overrides, unmatched_overrides
from turn_datasets.limits import MAX_FPS_HZ, MIN_FPS_HZ
from turn_datasets.mocap.readers import SourceFile, discover, read_source, sorted_sources
from turn_datasets.render.numbers import counted
from turn_datasets.skeleton import MocapSequence

__all__ = ["FileRecord", "MinedCorpus", "Sources", "find_sources", "mine_corpus", "write_corpus"]


@dataclass
class Sources:
    """The files to mine, in path order, and those named that could not even be opened."""

    files: list[SourceFile]
    unreadable: dict[Path, TurnbenchError] = field(default_factory=dict)

    @property
    def paths(self) -> list[Path]:
        return [f.path for f in self.files]


def find_sources(paths: Iterable[str | os.PathLike[str]], *, fmt: str | None = None) -> Sources:
    """Every source file under ``paths`` (:func:`turn_datasets.mocap.readers.discover`).

    A named file that cannot even be opened is kept, as unreadable (listed or skipped like
    any unreadable file) instead of stopping the search, and so is a subfolder that cannot be
    read (format ``folder``); a missing path or a folder with nothing to read is a mistake in
    the command and raises.
    """
    found: list[SourceFile] = []
    unreadable: dict[Path, TurnbenchError] = {}

    def folder_unreadable(folder: Path, exc: TurnbenchError) -> None:
        unreadable[folder] = exc
        found.append(SourceFile(folder, "folder"))

    for item in map(Path, paths):
        try:
            found.extend(discover([item], fmt=fmt, on_unreadable=folder_unreadable))
        except TurnbenchError as exc:
            if not item.is_file():
                raise
            unreadable[item] = exc
            found.append(SourceFile(item, fmt or "unknown"))
    return Sources(sorted_sources(found), unreadable)


@dataclass
class FileRecord:
    """What mining one source file gave: its clips and curation, and what it held."""

    source: SourceFile
    clips: list[SequenceClips] = field(default_factory=list)
    applied: list[dict[str, Any]] = field(default_factory=list)
    sequences: int = 0
    frames: int = 0
    units: set[str] = field(default_factory=set)
    #: The vertical axes the sequences were read with (generic arrays: stated or inferred).
    up_axes: set[str] = field(default_factory=set)
    #: 1 for a BVH whose rest-pose frame 0 was dropped: index frame k is the file's k + 1.
    frame_offset: int = 0
    bad_sequences: list[TurnbenchError] = field(default_factory=list)
    #: Why the file could not be read at all (its sequences read before failing are dropped).
    error: TurnbenchError | None = None

    def add(self, seq: MocapSequence, clips: SequenceClips, applied: list[dict]) -> None:
        self.clips.append(clips)
        self.applied.extend(applied)
        self.sequences += 1
        self.frames += seq.n_frames
        self.units.add(seq.units)
        if "up_axis" in seq.meta:
            self.up_axes.add(str(seq.meta["up_axis"]))
        self.frame_offset = int(bool(seq.meta.get("skipped_first_frame", False)))

    def manifest_entry(self) -> dict[str, Any]:
        path, read = self.source.path, self.error is None
        return {
            "path": str(path),
            "format": self.source.fmt,
            "sha256": _sha256_or_none(path),
            "bytes": path.stat().st_size if path.is_file() else None,
            "status": "read" if read else "skipped",
            "sequences": self.sequences if read else 0,
            "frames": self.frames if read else 0,
            "units": sorted(self.units) if read else [],
            "up_axes": sorted(self.up_axes) if read else [],
            "frame_offset": self.frame_offset,
            "skipped_sequences": len(self.bad_sequences) if read else 0,
        }


@dataclass
class MinedCorpus:
    """A mined corpus: the clip index, its manifest, and what was skipped or left unmatched."""

    index: pd.DataFrame
    manifest: dict[str, Any]
    records: list[FileRecord]
    unmatched: list[dict[str, Any]]
    #: What the run did that its options do not say (an unfiltered sequence, an implausible
    #: frame rate), one line each, also in the manifest's ``notes``.
    notes: list[str] = field(default_factory=list)

    @property
    def bad_files(self) -> list[FileRecord]:
        return [r for r in self.records if r.error is not None]

    @property
    def bad_sequences(self) -> list[TurnbenchError]:
        return [e for r in self.records if r.error is None for e in r.bad_sequences]

    @property
    def skipped(self) -> list[dict[str, Any]]:
        return list(self.manifest["skipped"])


def _sha256_or_none(path: Path) -> str | None:
    # a file that cannot even be opened was already reported as unreadable
    try:
        return sha256_file(path)
    except OSError:
        return None


def _sequences(
    records: Sequence[FileRecord], reader_options: Mapping[str, Any]
) -> Iterator[tuple[FileRecord, MocapSequence]]:
    for rec in records:
        if rec.error is not None:
            continue
        # In a file of many sequences one unusable sequence is listed or skipped alone; the
        # file's others are still read.
        try:
            for seq in read_source(
                rec.source, **reader_options, on_bad_sequence=rec.bad_sequences.append
            ):
                yield rec, seq
        except TurnbenchError as exc:
            path = rec.source.path
            rec.error = exc if exc.where.file else TurnbenchError(exc.message, file=path)


def _refuse_bad(
    records: Sequence[FileRecord], on_problem: Callable[[TurnbenchError], None] | None
) -> None:
    bad = [r.error for r in records if r.error is not None]
    bad_sequences = [e for r in records if r.error is None for e in r.bad_sequences]
    if not (bad or bad_sequences):
        return
    if on_problem is not None:
        for exc in [*bad, *bad_sequences]:
            on_problem(exc)
    what = [f"{len(bad)} of {len(records)} files could not be read"] if bad else []
    if bad_sequences:
        what.append(f"{len(bad_sequences)} sequence(s) could not be used")
    raise TurnbenchError(
        f"{' and '.join(what)}; nothing written",
        hint="fix or remove them, or pass --skip-bad to write the index without them",
    )


def _unfiltered_note(cutoff_hz: float, fps: float, names: Sequence[str]) -> str:
    """What the manifest and the warning say of sequences whose rate the cut-off does not fit
    (:func:`turn_datasets.h36m.miner.position_filter_applies`)."""
    side = (
        f"at or above {FILTER_MAX_FRACTION_OF_FPS:g} x {fps:g} Hz"
        if cutoff_hz >= FILTER_MAX_FRACTION_OF_FPS * fps
        else f"below {FILTER_MIN_FRACTION_OF_FPS:g} x {fps:g} Hz"
    )
    return (
        f"--position-cutoff-hz {cutoff_hz:g} is {side}: the hip positions of {len(names)} "
        f"sequence(s) at that rate were not filtered (first: {names[0]})"
    )


def mine_corpus(
    sources: Sources,
    params: MinerParams,
    reader_options: Mapping[str, Any],
    overrides: Overrides | None = None,
    *,
    fmt: str | None = None,
    skip_bad: bool = False,
    on_problem: Callable[[TurnbenchError], None] | None = None,
    iterate: Callable[[Iterator], Iterable] | None = None,
    created_utc: str | None = None,
) -> MinedCorpus:
    """Mine every sequence of ``sources`` into one clip index and its manifest.

    Parameters
    ----------
    sources
        From :func:`find_sources`.
    params
        The miner's parameters.
    reader_options
        ``layout, fps, up_axis, units, joint_map, skip_first_frame`` for
        :func:`turn_datasets.mocap.readers.read_source` (recorded in the manifest, with
        ``fmt`` as ``format``).
    overrides
        The curator's decisions (:func:`turn_datasets.h36m.overrides.read_overrides`).
    skip_bad
        Make the index without unreadable files and unusable sequences instead of failing.
    on_problem
        Called with each problem before the run fails on them (the command prints them).
    iterate
        Wraps the stream of sequences while they are mined (the command passes a progress
        bar).

    Raises
    ------
    TurnbenchError
        Bad files or sequences without ``skip_bad`` (after ``on_problem`` saw each), no
        sequence at all, or a curation error.
    """
    records = [FileRecord(f) for f in sources.files]
    for rec in records:
        rec.error = sources.unreadable.get(rec.source.path)
    stream = _sequences(records, reader_options)
    unfiltered: dict[float, list[str]] = {}
    odd_rates: list[str] = []
    for rec, seq in iterate(stream) if iterate is not None else stream:
        try:
            clips = mine_clips(seq, params)
        except TurnbenchError as exc:
            rec.bad_sequences.append(exc)
            continue
        rec.add(seq, *apply_overrides(seq, clips, overrides, params))
        # what the options do not say: a cut-off the miner had to ignore, a frame rate that
        # is no motion capture's (both mine silently otherwise: no filter, or no clip)
        name = f"{rec.source.path} ({seq.subject} {seq.action})"
        if params.position_cutoff_hz > 0 and not position_filter_applies(
            params.position_cutoff_hz, seq.fps
        ):
            unfiltered.setdefault(float(seq.fps), []).append(name)
        if not MIN_FPS_HZ <= seq.fps <= MAX_FPS_HZ:
            odd_rates.append(
                f"{name}: frame rate {seq.fps:g} Hz is outside the plausible "
                f"{MIN_FPS_HZ:g}-{MAX_FPS_HZ:g} Hz (a BVH Frame Time in the wrong unit?): "
                f"{counted(len(clips.start_frame), 'clip')} found"
            )
    if not skip_bad:
        _refuse_bad(records, on_problem)
    good = [r for r in records if r.error is None]
    if not any(r.sequences for r in good):
        raise TurnbenchError("no sequence could be read from the sources; nothing written")
    index = build_index(c for r in good for c in r.clips)
    applied = [a for r in good for a in r.applied]
    unmatched = unmatched_overrides(overrides, applied)
    skipped = [
        {"path": str(r.source.path), "item": None, "error": str(r.error)}
        for r in records
        if r.error is not None
    ]
    skipped += [
        {"path": str(r.source.path), "item": e.where.item, "error": str(e)}
        for r in good
        for e in r.bad_sequences
    ]
    notes = [
        _unfiltered_note(params.position_cutoff_hz, fps, names)
        for fps, names in sorted(unfiltered.items())
    ] + odd_rates
    manifest = build_manifest(
        index=index,
        params=params,
        reader_options={**reader_options, "format": fmt},
        inputs=[r.manifest_entry() for r in records],
        overrides=overrides,
        applied=applied,
        unmatched=unmatched,
        skipped=skipped,
        n_sequences=sum(r.sequences for r in good),
        n_frames=sum(r.frames for r in good),
        created_utc=created_utc,
    )
    # what was actually done, beside the options as given
    n_sequences = sum(r.sequences for r in good)
    n_unfiltered = (
        sum(len(v) for v in unfiltered.values()) if params.position_cutoff_hz > 0 else n_sequences
    )
    manifest["position_filter"] = {
        "cutoff_hz": float(params.position_cutoff_hz),
        "sequences_filtered": n_sequences - n_unfiltered,
        "sequences_unfiltered": n_unfiltered,
    }
    manifest["notes"] = notes
    return MinedCorpus(
        index=index, manifest=manifest, records=records, unmatched=unmatched, notes=notes
    )


def write_corpus(corpus: MinedCorpus, out: str | os.PathLike[str]) -> Path:
    """Write the index to ``out`` and the manifest beside it, both or neither; returns the
    manifest's path.

    Raises
    ------
    TurnbenchError
        A folder that cannot be made or written (a file in the way, no permission, full).
    """
    out = Path(out)
    mpath = manifest_path(out)
    try:
        with atomic_path(out) as tmp_index, atomic_path(mpath) as tmp_manifest:
            corpus.index.to_csv(tmp_index, index=False, lineterminator="\n")
            tmp_manifest.write_text(to_json_text(corpus.manifest), encoding="utf-8", newline="\n")
    except OSError as exc:
        # the file that failed (the manifest, if a folder of its name is in the way)
        raise TurnbenchError(
            f"cannot write the clip index: {exc.strerror or exc}", file=exc.filename or out
        ) from None
    return mpath
