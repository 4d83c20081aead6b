"""Atomic checkpoints with a clear error when one is corrupt or belongs to another configuration."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Any

import torch

FORMAT_VERSION = 1


class CheckpointError(RuntimeError):
    """A checkpoint that cannot be read or does not match the run that loads it."""


def config_fingerprint(config: dict[str, Any], ignore: tuple[str, ...] = ()) -> str:
    """Hash of the settings that must match for a checkpoint to be resumed (``ignore``: top-level
    keys that may change between the run and its resumption, such as the length of training)."""
    kept = {k: v for k, v in config.items() if k not in ignore}
    return hashlib.sha256(json.dumps(kept, sort_keys=True).encode()).hexdigest()[:16]


def atomic_save(obj: Any, path: Path | str) -> None:
    """``torch.save`` to a temporary file in the same folder, flushed, then renamed over ``path``:
    a crash leaves the previous checkpoint whole."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            torch.save(obj, fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def save_checkpoint(path: Path | str, state: dict[str, Any], fingerprint: str) -> None:
    atomic_save({"format_version": FORMAT_VERSION, "fingerprint": fingerprint, **state}, path)


def load_checkpoint(path: Path | str, fingerprint: str | None = None,
                    required: tuple[str, ...] = ()) -> dict[str, Any]:
    """Read a checkpoint written by ``save_checkpoint``.

    Raises:
        CheckpointError: missing or unreadable file, another format, a configuration that does not
            match ``fingerprint``, or a missing entry of ``required``.
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint at {path}")
    try:
        data = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as err:  # pickle, zip and torch errors all mean the same here
        raise CheckpointError(f"checkpoint {path} is corrupt or not a checkpoint: {err}") from err
    if not isinstance(data, dict) or data.get("format_version") != FORMAT_VERSION:
        raise CheckpointError(f"checkpoint {path} has an unknown format")
    if fingerprint is not None and data.get("fingerprint") != fingerprint:
        raise CheckpointError(f"checkpoint {path} was written by a run with other settings "
                              f"(fingerprint {data.get('fingerprint')}, this run {fingerprint})")
    missing = [k for k in required if k not in data]
    if missing:
        raise CheckpointError(f"checkpoint {path} lacks {missing}")
    return data
