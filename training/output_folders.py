"""The output folder of a command that writes its results to a folder (report, benchmark, sweep,
loop bench, evaluate's plots, the effectiveness figure).

A command records in its folder a manifest (``MANIFEST``: which command wrote it and the files it
wrote), and, before any work (``OutputFolder.claim``):

- refuses a folder whose manifest names another command: two commands' results are never mixed;
- refuses a folder holding files it would write (its ``results``: names or glob patterns) that no
  earlier run of it recorded, with or without a manifest: a command never replaces what it did not
  write (documentation figures matching ``fig*.png``, a user's ``command.txt``);
- refuses a folder holding its own earlier results unless ``overwrite``.

It then writes into a new temporary folder next to the destination (``OutputFolder.staging``) and
moves its files into place only when everything succeeded (``OutputFolder.commit``): an error or a
Ctrl-C before that leaves the earlier results as they were, and removes the temporary folder. With
``overwrite``, the earlier run's recorded files that the new run does not write again are removed
at the commit, and nothing else.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from training.runtime import OutputFolderError, check_output_folder

MANIFEST = "written_by.json"  # in every output folder: the command and the files it wrote
MANIFEST_VERSION = 1
STAGING_PREFIX = ".staging_"  # the temporary folders next to a destination


def _names(paths: Iterable[Path]) -> str:
    names = sorted(p.name for p in paths)
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def write_json_atomic(path: Path | str, data, **dump_options) -> None:
    """``path`` holds ``data`` as JSON, whole or as it was: written to a temporary file beside it,
    flushed to disk, then renamed over it (a reader never sees a truncated file)."""
    write_text_atomic(path, json.dumps(data, **dump_options))


def write_text_atomic(path: Path | str, text: str) -> None:
    """``path`` holds ``text``, whole or as it was (see ``write_json_atomic``)."""
    _write_atomic(path, text, "w")


def write_bytes_atomic(path: Path | str, data: bytes) -> None:
    """``path`` holds ``data``, whole or as it was (see ``write_json_atomic``)."""
    _write_atomic(path, data, "wb")


def _write_atomic(path: Path | str, data: str | bytes, mode: str) -> None:
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, mode) as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def read_json(path: Path | str):
    """The JSON in ``path``; ``OutputFolderError`` (one line naming the file) where it cannot be
    read or is not JSON (truncated by a stop during an earlier, non-atomic write)."""
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as err:
        why = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise OutputFolderError(f"{path} is damaged or unreadable ({why}): remove it to write it again") from None


def read_manifest(folder: Path | str) -> dict | None:
    """The manifest of ``folder``: None where it has none; ``OutputFolderError`` (one line) where
    it cannot be read."""
    path = Path(folder) / MANIFEST
    if not path.exists():
        return None
    try:
        manifest = read_json(path)
        if not (isinstance(manifest, dict) and isinstance(manifest.get("command"), str)
                and isinstance(manifest.get("files"), list) and all(isinstance(f, str) for f in manifest["files"])):
            raise ValueError("not a manifest")
    except OutputFolderError:
        raise
    except ValueError as err:
        raise OutputFolderError(f"{path} is damaged ({err}): the folder's owner is unknown; give another folder") from None
    return manifest


class OutputFolder:
    """The folder ``folder`` that the command ``command`` (its script's name) writes ``results`` to
    (file names or glob patterns: what the command may write). ``claim`` before any work, write
    into ``stage()``'s folder, ``commit`` at the end; ``writing`` does the last two and removes the
    temporary folder on any error or Ctrl-C."""

    def __init__(self, folder: Path | str, command: str, results: Iterable[str], overwrite: bool = False,
                 invocation: str | None = None) -> None:
        self.folder = Path(folder)
        self.command = command
        self.results = tuple(results)
        self.overwrite = overwrite
        self.invocation = invocation  # the command line, for the manifest
        self.staging: Path | None = None
        self._earlier: list[str] = []

    # ------------------------------------------------------------------ before any work
    def claim(self) -> OutputFolder:
        """Refuse (``OutputFolderError``, one line) a folder this command may not write to; see
        the module's description. Nothing is written."""
        folder = check_output_folder(self.folder)
        self._earlier = self._check_owner(folder)
        return self

    def _matching(self, folder: Path) -> set[Path]:
        return {p for pattern in self.results for p in folder.glob(pattern) if p.is_file()}

    def _check_owner(self, folder: Path) -> list[str]:
        """The earlier run's recorded files that exist, after the checks of ``claim``."""
        if not folder.is_dir():
            return []
        manifest = read_manifest(folder)
        if manifest is not None and manifest["command"] != self.command:
            raise OutputFolderError(f"{folder} holds the results of {manifest['command']} (its {MANIFEST}): "
                                    f"give another folder for {self.command}'s")
        recorded = set(manifest["files"]) if manifest is not None else set()
        foreign = {p for p in self._matching(folder) if p.name not in recorded}
        if foreign:
            raise OutputFolderError(f"{folder} holds files {self.command} would write that no earlier run of it "
                                    f"recorded ({_names(foreign)}): give another folder, or move them away")
        earlier = sorted(name for name in recorded if (folder / name).is_file())
        if earlier and not self.overwrite:
            raise OutputFolderError(f"{folder} holds the results of an earlier run ({_names(map(Path, earlier))}): "
                                    "give another folder, or --overwrite to replace them")
        return earlier

    # ------------------------------------------------------------------ the work
    def stage(self) -> Path:
        """A new, empty temporary folder next to the destination (the same file system, so that
        the commit is a rename of each file); the command writes its files there."""
        if self.staging is None:
            parent = self.folder.parent
            parent.mkdir(parents=True, exist_ok=True)
            self.staging = Path(tempfile.mkdtemp(dir=parent, prefix=f"{STAGING_PREFIX}{self.folder.name}_"))
        return self.staging

    def discard(self) -> None:
        """Remove the temporary folder (and whatever was not committed)."""
        if self.staging is not None:
            shutil.rmtree(self.staging, ignore_errors=True)
            self.staging = None

    def commit(self) -> list[Path]:
        """Move the staged files into the folder, replacing only the earlier run's recorded files
        (``claim`` is checked again: the folder may have changed during the work); returns the
        files now in place. The manifest names every file of this command in the folder at every
        moment: first the earlier and the new files, then the new alone."""
        if self.staging is None:
            raise RuntimeError("commit before stage")
        staged = sorted(p for p in self.staging.iterdir() if p.is_file())
        self._earlier = self._check_owner(self.folder) if self.folder.is_dir() else []
        names = [p.name for p in staged]
        if MANIFEST in names:
            raise RuntimeError(f"a command may not write {MANIFEST} itself")
        self.folder.mkdir(parents=True, exist_ok=True)
        record = {"version": MANIFEST_VERSION, "command": self.command, "invocation": self.invocation}
        write_json_atomic(self.folder / MANIFEST, {**record, "files": sorted(set(names) | set(self._earlier))},
                          indent=1)
        for path in staged:
            os.replace(path, self.folder / path.name)
        for name in set(self._earlier) - set(names):
            with contextlib.suppress(FileNotFoundError):
                (self.folder / name).unlink()
        write_json_atomic(self.folder / MANIFEST, {**record, "files": names}, indent=1)
        self.discard()
        return [self.folder / name for name in names]


@contextlib.contextmanager
def writing(folder: OutputFolder) -> Iterator[Path]:
    """``with writing(claimed) as staging: ...``: the staging folder, committed when the block
    ends without an error, discarded otherwise."""
    try:
        yield folder.stage()
        folder.commit()
    finally:
        folder.discard()
