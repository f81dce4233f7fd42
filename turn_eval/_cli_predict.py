"""Commands of turn-eval (registered on the group in turn_eval.cli)."""

from __future__ import annotations
