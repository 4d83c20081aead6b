"""Atomic, checksummed checkpoints and policy files, with a clear error when one is damaged, holds
non-finite numbers, or belongs to another configuration.

A file written by ``atomic_save`` is ``MAGIC``, the SHA-256 of the payload, then the payload
(``torch.save``'s bytes): a single changed byte anywhere is caught on load, before unpickling.
Files from before the checksum (a ``torch.save`` zip) still load, checked for non-finite numbers.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tempfile
from pathlib import Path
from typing import Any

import torch

FORMAT_VERSION = 1
MAGIC = b"SOLARUAV-CHECKED-1\n"
_DIGEST_SIZE = 32


class DamagedFileError(ValueError):
    """A checked file whose contents no longer match their checksum, or that cannot be read."""


class _HashingWriter(io.RawIOBase):
    """A write-only file that passes every byte to ``fh`` and to a SHA-256, so that a checkpoint
    is hashed as it is written, without a second copy of it in memory."""

    def __init__(self, fh):
        self.fh, self.sha = fh, hashlib.sha256()

    def writable(self) -> bool:
        return True

    def write(self, data) -> int:
        self.sha.update(data)
        return self.fh.write(data)


def write_checked(obj: Any, fh) -> None:
    """Write ``obj`` as a checked file (``MAGIC``, SHA-256, ``torch.save`` payload) to the
    seekable binary file ``fh``, from its start."""
    fh.write(MAGIC + bytes(_DIGEST_SIZE))  # the digest's place, filled in once it is known
    writer = _HashingWriter(fh)
    torch.save(obj, writer)
    fh.seek(len(MAGIC))
    fh.write(writer.sha.digest())
    fh.seek(0, io.SEEK_END)


def checked_load(path: Path | str) -> Any:
    """Read a file written by ``atomic_save`` (or an older plain ``torch.save`` file).

    Raises:
        FileNotFoundError: no file at ``path``.
        DamagedFileError: the checksum does not match, or the payload cannot be unpickled.
    """
    path = Path(path)
    raw = path.read_bytes()
    if raw.startswith(MAGIC):
        digest = raw[len(MAGIC):len(MAGIC) + _DIGEST_SIZE]
        payload = memoryview(raw)[len(MAGIC) + _DIGEST_SIZE:]
        if hashlib.sha256(payload).digest() != digest:
            raise DamagedFileError(f"{path} is damaged: its contents do not match the SHA-256 written with them")
        source: Any = io.BytesIO(payload)
    else:
        source = io.BytesIO(raw)  # written before the checksum
    try:
        return torch.load(source, map_location="cpu", weights_only=False)
    except Exception as err:  # pickle, zip and torch errors all mean the same here
        raise DamagedFileError(f"{path} is damaged or not a file of this package: {err}") from err


def non_finite_entries(obj: Any, name: str = "") -> list[str]:
    """Names of the floating-point tensors in ``obj`` (nested dicts, lists, TensorDicts) that hold
    NaN or infinity."""
    if isinstance(obj, torch.Tensor):
        if obj.is_floating_point() and obj.numel() and not bool(torch.isfinite(obj).all()):
            return [name or "tensor"]
        return []
    if hasattr(obj, "items"):  # dict, OrderedDict, TensorDict
        items = obj.items(include_nested=False) if hasattr(obj, "batch_size") else obj.items()
        return [n for k, v in items for n in non_finite_entries(v, f"{name}.{k}" if name else str(k))]
    if isinstance(obj, (list, tuple)):
        return [n for i, v in enumerate(obj) for n in non_finite_entries(v, f"{name}[{i}]")]
    return []


class CheckpointError(RuntimeError):
    """A checkpoint that cannot be read or does not match the run that loads it."""


def config_fingerprint(config: dict[str, Any], ignore: tuple[str, ...] = ()) -> str:
    """Hash of the settings that must match for a checkpoint to be resumed (``ignore``: top-level
    keys that may change between the run and its resumption, such as the length of training)."""
    kept = {k: v for k, v in config.items() if k not in ignore}
    return hashlib.sha256(json.dumps(kept, sort_keys=True).encode()).hexdigest()[:16]


def atomic_save(obj: Any, path: Path | str) -> None:
    """``obj`` as a checked file (module docstring) written to a temporary file in the same folder,
    flushed, then renamed over ``path``: a crash leaves the previous file whole."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            write_checked(obj, fh)
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
        CheckpointError: missing, damaged or unreadable file, another format, NaN or infinity in
            the weights, optimiser or replay buffer, a configuration that does not match
            ``fingerprint``, or a missing entry of ``required``.
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint at {path}")
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
