"""The signature of a scoring output: what a reader needs to reproduce its numbers.

In the manner of sacrebleu's signature (Post 2018, "A Call for Clarity in Reporting BLEU
Scores"): one line, ``|``-separated ``key:value`` fields, that names the command, every option
that changes a number, the sha256 of each input file (its first 12 hex digits on the line, all
64 in the JSON) and turnbench's version::

    turnbench-score|by:subject|bin:45|bootstrap:percentile-1000|seed:0|reference:3f2a…|predictions:9c1e…|version:0.9.0

``score``, ``score-events`` and ``compare`` end their Markdown with it (``signature: …``) and
carry it in their JSON as an object (:meth:`Signature.as_dict`): ``command``, ``version``,
``options`` (the line's option fields) and ``<role>_sha256`` per input.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from turn_datasets import __version__
from turn_datasets.fileio import sha256_file

__all__ = ["SHORT_SHA", "Signature", "signature_line"]

#: Hex digits of a file's sha256 printed on the line (the JSON holds all 64).
SHORT_SHA = 12


@dataclass(frozen=True)
class Signature:
    """A command's options and its inputs' sha256, as one line and as a JSON object.

    Attributes
    ----------
    command
        ``score``, ``score-events`` or ``compare``.
    options
        ``(name, value)`` in the order printed; a value is printed with ``str`` (a sequence
        joined with commas, a bool as ``yes``/``no``).
    sha256
        ``(role, hex digest)`` of each input file (``reference``, ``predictions``, ...).
    version
        turnbench's version.
    """

    command: str
    options: tuple[tuple[str, str], ...]
    sha256: tuple[tuple[str, str], ...]
    version: str = __version__

    @classmethod
    def of(
        cls,
        command: str,
        options: Sequence[tuple[str, object]],
        inputs: Mapping[str, str | os.PathLike[str] | None],
        digests: Mapping[str, str | None] | None = None,
    ) -> Signature:
        """The signature of a run: ``inputs`` maps each role to its file (a role whose file is
        None or not a file, such as a table built in memory, is left out). ``digests`` gives
        the sha256 a reader took of the bytes it read
        (:attr:`turn_datasets.usertable.Table.sha256`), so that file is not read again; a
        role without one is hashed here."""
        known = digests or {}
        sha256 = []
        for role, path in inputs.items():
            digest = known.get(role)
            if path is not None and digest:
                sha256.append((role, digest))
            elif path is not None and os.path.isfile(path):
                sha256.append((role, sha256_file(path)))
        return cls(command, tuple((name, _text(value)) for name, value in options), tuple(sha256))

    @property
    def options_text(self) -> str:
        """The option fields of the line, ``name:value|...``."""
        return "|".join(f"{name}:{value}" for name, value in self.options)

    def line(self) -> str:
        """``turnbench-<command>|<options>|<role>:<sha256[:12]>|...|version:<version>``."""
        fields = [f"turnbench-{self.command}"]
        if self.options:
            fields.append(self.options_text)
        fields += [f"{role}:{digest[:SHORT_SHA]}" for role, digest in self.sha256]
        fields.append(f"version:{self.version}")
        return "|".join(fields)

    def as_dict(self) -> dict[str, Any]:
        """The JSON ``signature`` object."""
        out: dict[str, Any] = {
            "command": self.command,
            "version": self.version,
            "options": self.options_text,
        }
        out.update({f"{role}_sha256": digest for role, digest in self.sha256})
        return out


def signature_line(doc: Mapping[str, Any]) -> str:
    """The line of a JSON ``signature`` object (:meth:`Signature.as_dict`), as printed at the
    end of the Markdown."""
    sha = tuple(
        (key.removesuffix("_sha256"), str(value))
        for key, value in doc.items()
        if key.endswith("_sha256")
    )
    options = tuple(
        (name, value)
        for name, _, value in (f.partition(":") for f in str(doc.get("options", "")).split("|"))
        if name
    )
    return Signature(str(doc["command"]), options, sha, str(doc["version"])).line()


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float) and value.is_integer():
        return f"{int(value)}"
    if isinstance(value, (list, tuple)):
        return ",".join(_text(v) for v in value) or "-"
    return str(value)
