"""Commands of turn-datasets (registered on the groups in turn_datasets.cli)."""

from __future__ import annotations
