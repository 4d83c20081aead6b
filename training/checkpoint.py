"""Training checkpoints: checked files (``jsbsim_env.control.checked_io``) with a format version and
the fingerprint of the run's settings, refused with a clear error when damaged, non-finite, or of
another configuration."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from jsbsim_env.control.checked_io import (
    DamagedFileError,
    atomic_save,
    checked_load,
    non_finite_entries,
)

FORMAT_VERSION = 1
class CheckpointError(RuntimeError):
    """A checkpoint that cannot be read or does not match the run that loads it."""


def config_fingerprint(config: dict[str, Any], ignore: tuple[str, ...] = ()) -> str:
    """Hash of the settings that must match for a checkpoint to be resumed (``ignore``: top-level
    keys that may change between the run and its resumption, such as the length of training)."""
    kept = {k: v for k, v in config.items() if k not in ignore}
    return hashlib.sha256(json.dumps(kept, sort_keys=True).encode()).hexdigest()[:16]


def not_a_file_message(path: Path) -> str | None:
    """What ``path`` is where a file of a run is expected and something else is there (a folder, a
    device, a socket); None where it is a file or nothing (a dangling link is nothing)."""
    if not path.exists() or path.is_file():
        return None
    kind = "a folder" if path.is_dir() else "not a regular file"
    return (f"{path} is {kind}, not the file a run writes there: move it away, then resume from a copy of the "
            "run's checkpoint or start the run afresh")


def save_checkpoint(path: Path | str, state: dict[str, Any], fingerprint: str) -> None:
    atomic_save({"format_version": FORMAT_VERSION, "fingerprint": fingerprint, **state}, path)


def load_checkpoint(path: Path | str, fingerprint: str | None = None,
                    required: tuple[str, ...] = ()) -> dict[str, Any]:
    """Read a checkpoint written by ``save_checkpoint``.

    Raises:
        CheckpointError: missing, damaged or unreadable file, another format, NaN or infinity in
            the weights, optimiser or replay buffer, a configuration that does not match
            ``fingerprint``, or a missing entry of ``required``.
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(not_a_file_message(path) or f"no checkpoint at {path}")
    try:
        data = checked_load(path)
    except DamagedFileError as err:
        raise CheckpointError(f"checkpoint {err}; resume from an earlier copy or start the run again") from err
    if not isinstance(data, dict) or data.get("format_version") != FORMAT_VERSION:
        raise CheckpointError(f"checkpoint {path} has an unknown format")
    bad = non_finite_entries({k: data[k] for k in ("sac", "optimizer", "buffer") if k in data})
    if bad:
        shown = ", ".join(bad[:5]) + (f" and {len(bad) - 5} more" if len(bad) > 5 else "")
        raise CheckpointError(f"checkpoint {path} holds NaN or infinite values in {shown}")
    if fingerprint is not None and data.get("fingerprint") != fingerprint:
        raise CheckpointError(f"checkpoint {path} was written by a run with other settings "
                              f"(fingerprint {data.get('fingerprint')}, this run {fingerprint})")
    missing = [k for k in required if k not in data]
    if missing:
        raise CheckpointError(f"checkpoint {path} lacks {missing}")
    return data
