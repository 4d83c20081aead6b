"""Checked files: written atomically with a SHA-256 of their contents, refused on load when a byte
has changed; ``non_finite_entries`` names the weights that are not finite, for the loaders to
refuse. Policy files and training checkpoints are both such files.

A file written by ``atomic_save`` is ``MAGIC``, the SHA-256 of the payload, then the payload
(``torch.save``'s bytes): a single changed byte anywhere is caught on load, before unpickling.
Files from before the checksum (a ``torch.save`` zip) still load, checked for non-finite numbers.
"""

from __future__ import annotations

import hashlib
import io
import os
import tempfile
from pathlib import Path
from typing import Any

import torch

MAGIC = b"SOLARUAV-CHECKED-1\n"
_DIGEST_SIZE = 32


class DamagedFileError(ValueError):
    """A checked file whose contents no longer match their checksum, or that cannot be read."""


class _HashingWriter(io.RawIOBase):
    """A write-only file that passes every byte to ``fh`` and to a SHA-256, so that a checkpoint
    is hashed as it is written, without a second copy of it in memory."""

    def __init__(self, fh):
        self.fh, self.sha = fh, hashlib.sha256()
        self.error: OSError | None = None  # the write that failed (torch reports it as a RuntimeError)

    def writable(self) -> bool:
        return True

    def write(self, data) -> int:
        self.sha.update(data)
        try:
            return self.fh.write(data)
        except OSError as err:
            self.error = err
            raise


def write_checked(obj: Any, fh) -> None:
    """Write ``obj`` as a checked file (``MAGIC``, SHA-256, ``torch.save`` payload) to the
    seekable binary file ``fh``, from its start."""
    fh.write(MAGIC + bytes(_DIGEST_SIZE))  # the digest's place, filled in once it is known
    writer = _HashingWriter(fh)
    try:
        torch.save(obj, writer)
    except RuntimeError:
        if writer.error is not None:  # a full disk, say: the OSError, as every other write raises it
            raise writer.error from None
        raise
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
