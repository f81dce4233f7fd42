"""A challenge's data directory: its settings, the hidden reference, the split, the secret.

Layout (nothing in it is served: the server answers only its API routes and the page)::

    DIR/challenge.json          the settings (ChallengeParams, groups, database, versions)
    DIR/private/reference.csv   a copy of the reference (owner-only folder)
    DIR/private/split.csv       clip_id, split (public/private), as drawn at init
    DIR/private/secret          the HMAC key of the receipts (owner-only)
    DIR/uploads/<id>.csv        each accepted upload, under its id, never the user's name
    DIR/incoming/               uploads being received and validated (removed after)
    DIR/turnbench.db            the SQLite database, unless ``--db`` gave a URL
"""

from __future__ import annotations

import json
import os
import secrets
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from turn_datasets import __version__
from turn_datasets.errors import TurnbenchError
from turn_datasets.params import check_params, param

__all__ = [
    "ChallengeParams",
    "Challenge",
    "SETTINGS_FILE",
    "open_challenge",
    "sqlite_url",
    "new_secret",
    "REFERENCE_NAME",
]

SETTINGS_FILE = "challenge.json"
#: The name the reference goes by in every message the server sends (never its path).
REFERENCE_NAME = "reference.csv"
SQLITE_FILE = "turnbench.db"


@dataclass(frozen=True)
class ChallengeParams:
    """The numbers a challenge is run with, fixed at ``server init``."""

    daily_quota: int = param(5, "Submissions a team may make per UTC day.", min=1, max=10_000)
    total_quota: int = param(100, "Submissions a team may make in the phase.", min=1, max=1_000_000)
    private_fraction: float = param(
        0.5,
        "Share of participants (else clips) held out for the private leaderboard.",
        min=0,
        min_open=True,
        max=0.95,
    )
    max_upload_mb: float = param(
        5.0,
        "Largest upload accepted, in MiB (larger is refused while streaming).",
        min=0,
        min_open=True,
        max=1024,
    )
    rank_alpha: float = param(
        0.05,
        "Level of the paired bootstrap that separates a rank from the one above it.",
        min=0,
        min_open=True,
        max=0.5,
    )


@dataclass(frozen=True)
class Challenge:
    """A challenge as its data directory records it.

    Attributes
    ----------
    root
        The data directory.
    name
        The challenge's title, shown on the page.
    params
        :class:`ChallengeParams`.
    by
        The reference columns the leaderboard shows per group (all that leaves the reference).
    seed, n_resamples
        Seed of the split and of every bootstrap; resamples of the intervals and rank tests.
    database
        A SQLAlchemy URL, or None for the SQLite file in the directory.
    reference_version
        The sha256 of the reference (receipts carry it).
    split
        How the split was drawn: unit, counts, and the sha256 of ``split.csv``.
    """

    root: Path
    name: str
    params: ChallengeParams
    by: tuple[str, ...]
    seed: int
    n_resamples: int
    database: str | None
    reference_version: str
    split: dict[str, Any] = field(default_factory=dict)
    created: str = ""
    version: str = __version__

    @property
    def private_dir(self) -> Path:
        return self.root / "private"

    @property
    def reference_path(self) -> Path:
        return self.private_dir / "reference.csv"

    @property
    def split_path(self) -> Path:
        return self.private_dir / "split.csv"

    @property
    def secret_path(self) -> Path:
        return self.private_dir / "secret"

    @property
    def uploads_dir(self) -> Path:
        return self.root / "uploads"

    @property
    def incoming_dir(self) -> Path:
        return self.root / "incoming"

    def upload_path(self, submission_id: str) -> Path:
        """Where an accepted upload is kept: named by its id alone."""
        if not submission_id.isalnum():
            raise TurnbenchError(f"not a submission id: {submission_id!r}")
        return self.uploads_dir / f"{submission_id}.csv"

    @property
    def database_url(self) -> str:
        return self.database or sqlite_url(self.root / SQLITE_FILE)

    def secret(self) -> bytes:
        return bytes.fromhex(self.secret_path.read_text().strip())

    def read_split(self) -> pd.DataFrame:
        return pd.read_csv(self.split_path, dtype=str, keep_default_na=False)

    def as_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "params": asdict(self.params),
            "by": list(self.by),
            "seed": self.seed,
            "bootstrap": self.n_resamples,
            "database": self.database,
            "reference_version": self.reference_version,
            "split": self.split,
            "created": self.created,
            "version": self.version,
        }


def sqlite_url(path: Path) -> str:
    return f"sqlite:///{path.resolve()}"


def new_secret() -> str:
    """32 random bytes from the OS (:func:`secrets.token_hex`), as hex."""
    return secrets.token_hex(32)


def open_challenge(root: str | os.PathLike[str]) -> Challenge:
    """Read a data directory made by ``turn-eval server init``.

    Raises
    ------
    TurnbenchError
        The folder is not one (no settings file) or its settings are unreadable.
    """
    root = Path(root)
    settings = root / SETTINGS_FILE
    if not settings.is_file():
        raise TurnbenchError(
            f"not a challenge data directory (no {SETTINGS_FILE})",
            file=str(root),
            hint="make one with: turn-eval server init DIR --reference labels.csv --name NAME",
        )
    try:
        doc = json.loads(settings.read_text(encoding="utf-8"))
        params = ChallengeParams(**doc["params"])
        check_params(params)
        return Challenge(
            root=root,
            name=str(doc["name"]),
            params=params,
            by=tuple(doc["by"]),
            seed=int(doc["seed"]),
            n_resamples=int(doc["bootstrap"]),
            database=doc["database"],
            reference_version=str(doc["reference_version"]),
            split=dict(doc["split"]),
            created=str(doc.get("created", "")),
            version=str(doc.get("version", "")),
        )
    except (ValueError, KeyError, TypeError) as exc:
        raise TurnbenchError(f"unreadable challenge settings ({exc})", file=str(settings)) from None
