"""Reading a run's ``progress.csv`` as a killed or powered-off run may have left it.

Every row ends with a line break, so what follows the last one is a row cut short; power loss can
also leave NUL bytes or a partial row anywhere a write was under way. ``read_progress`` keeps the
readable rows and counts the rest, for the trainer's resume, the soak, the curves and the
provenance records alike.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path


def read_progress(path: Path | str, fields: Sequence[str] | None = None) -> tuple[list[dict[str, str]], int]:
    """The readable rows of a progress log (a dict per row, by the header's names, each with an
    integer ``frames``) and how many rows could not be read. Raises ``OSError`` when the file
    cannot be read at all.

    ``fields``: the header its writer writes first (the trainer's ``CSV_FIELDS``). The rows are
    then also read under that header in place of the file's first line, and whichever reading
    keeps more rows is taken: a damaged byte in the header (or a header lost to a torn write)
    loses no row, and a log of an older layout is still read by its own header. Without
    ``fields`` the rows before the first readable header are dropped."""
    lines = Path(path).read_bytes().decode("utf-8", errors="replace").split("\n")
    found = _read(lines, None)
    if fields is None:
        return found
    known = _read(lines, list(fields))
    return known if len(known[0]) >= len(found[0]) else found


def _read(lines: list[str], header: list[str] | None) -> tuple[list[dict[str, str]], int]:
    """``read_progress`` under ``header`` (the first line is its place, and dropped unless it is a
    row), or under the first readable line naming ``frames`` (None)."""
    dropped = 1 if lines[-1].strip("\0\r ") else 0
    rows = []
    place = header is not None  # the first line holds the header's place
    for number, line in enumerate(lines[:-1]):
        fields = _fields(line)
        readable = bool(fields)
        if header is None:
            if readable and "frames" in fields:
                header = fields
            else:
                dropped += 1 if line.strip("\0\r ") else 0
            continue
        row = dict(zip(header, fields))
        if fields and _is_row(row, fields, header):
            rows.append(row)
        elif not (place and number == 0):
            dropped += 1 if fields or line.strip("\0\r ") else 0
    return rows, dropped


def _fields(line: str) -> list[str]:
    """The fields of one line; none where it holds NUL bytes, undecodable bytes or a stray line
    break (what a damaged or torn write leaves)."""
    if "\0" in line or "\ufffd" in line:
        return []
    try:
        return next(csv.reader(io.StringIO(line)), [])
    except csv.Error:
        return []


def _is_row(row: dict[str, str], fields_read: list[str], header: list[str]) -> bool:
    """Whether a line read under ``header`` is a whole row: every field, an integer ``frames``."""
    if len(fields_read) != len(header):
        return False
    try:
        int(row["frames"])
    except (KeyError, ValueError):
        return False
    return True


__all__ = ["read_progress"]
