"""Signed receipts: what a team can show that the server scored its file as it says.

A receipt is a JSON object of the submission's id, its team, the sha256 of the uploaded file,
the reference's version (the sha256 of the hidden reference), turnbench's version and the
public scores, with ``signature``: the HMAC-SHA256 (RFC 2104, :mod:`hmac`) under the server's
secret of the canonical JSON of everything else (sorted keys, no spaces, UTF-8). Only the
holder of the secret can make one; :func:`verify_receipt` recomputes it and compares in
constant time (:func:`hmac.compare_digest`).
"""

from __future__ import annotations

import hashlib
import hmac
import json
from collections.abc import Mapping
from typing import Any

__all__ = ["RECEIPT_FIELDS", "canonical_bytes", "sign_receipt", "verify_receipt"]

#: The fields a receipt signs, all of them required.
RECEIPT_FIELDS = (
    "submission",
    "team",
    "sha256",
    "reference_version",
    "turnbench_version",
    "public_scores",
)


def canonical_bytes(payload: Mapping[str, Any]) -> bytes:
    """The bytes the signature covers: sorted keys, no whitespace, UTF-8, no NaN."""
    return json.dumps(
        payload, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False
    ).encode("utf-8")


def _mac(secret: bytes, payload: Mapping[str, Any]) -> str:
    return hmac.new(secret, canonical_bytes(payload), hashlib.sha256).hexdigest()


def sign_receipt(secret: bytes, payload: Mapping[str, Any]) -> dict[str, Any]:
    """``payload`` (the :data:`RECEIPT_FIELDS`) with its ``signature`` added."""
    body = {name: payload[name] for name in RECEIPT_FIELDS}
    return {**body, "signature": _mac(secret, body)}


def verify_receipt(secret: bytes, receipt: Mapping[str, Any]) -> tuple[bool, str]:
    """Whether ``receipt`` was signed with ``secret`` and left unchanged since.

    Returns
    -------
    (bool, str)
        The verdict and, when it is False, why (a missing field, an extra field, a
        signature that does not match).
    """
    missing = [name for name in (*RECEIPT_FIELDS, "signature") if name not in receipt]
    if missing:
        return False, f"the receipt lacks {', '.join(missing)}"
    extra = sorted(set(receipt) - {*RECEIPT_FIELDS, "signature"})
    if extra:
        return False, f"the receipt has fields no receipt is signed with: {', '.join(extra)}"
    signature = receipt["signature"]
    if not isinstance(signature, str):
        return False, "the signature is not a string"
    body = {name: receipt[name] for name in RECEIPT_FIELDS}
    try:
        expected = _mac(secret, body)
    except (TypeError, ValueError) as exc:
        return False, f"the receipt's fields are not plain JSON ({exc})"
    if hmac.compare_digest(expected.encode(), signature.encode("utf-8", "replace")):
        return True, "the signature matches"
    return False, "the signature does not match: the receipt was changed or not made here"
