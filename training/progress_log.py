"""Reading a run's ``progress.csv`` as a killed or powered-off run may have left it.

Every row ends with a line break, so what follows the last one is a row cut short; power loss can
also leave NUL bytes or a partial row anywhere a write was under way. ``read_progress`` keeps the
readable rows and counts the rest, for the trainer's resume, the soak, the curves and the
provenance records alike.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path


def read_progress(path: Path | str) -> tuple[list[dict[str, str]], int]:
    """The readable rows of a progress log (a dict per row, by the header's names, each with an
    integer ``frames``) and how many rows could not be read. Raises ``OSError`` when the file
    cannot be read at all."""
    text = Path(path).read_bytes().decode("utf-8", errors="replace")
    lines = text.split("\n")
    dropped = 1 if lines[-1].strip("\0\r ") else 0
    header, rows = None, []
    for line in lines[:-1]:
        readable = "\0" not in line and "\ufffd" not in line
        fields = next(csv.reader(io.StringIO(line)), []) if readable else []
        if header is None:
            if readable and "frames" in fields:
                header = fields
            else:
                dropped += 1 if line.strip("\0\r ") else 0
            continue
        if not fields:
            dropped += 1 if line.strip("\0\r ") else 0
            continue
        row = dict(zip(header, fields))
        try:
            int(row["frames"])
        except ValueError:
            dropped += 1
            continue
        if len(fields) != len(header):
            dropped += 1
            continue
        rows.append(row)
    return rows, dropped


__all__ = ["read_progress"]
