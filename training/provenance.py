"""Where a run came from: each training session appends one line to ``RUN_DIR/sessions.jsonl``
with the command, the commit (and whether the tree had uncommitted changes), the fingerprint of
the aircraft model it flew, the step count it started at and the CPU cores it could use, so a shipped policy can name the
exact commands, commits and aircraft that produced it.
"""

from __future__ import annotations

import json
import shlex
import subprocess
import time
from pathlib import Path

import aircraft
from training.progress_log import read_progress
from training.runtime import available_cores

SESSIONS_FILE = "sessions.jsonl"
REPO_ROOT = Path(__file__).resolve().parents[1]


def git_commit(repo: Path = REPO_ROOT) -> tuple[str | None, bool]:
    """The checked-out commit and whether the tree differs from it (changed files, or new files
    that are not ignored); (None, False) outside git or without git."""
    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", *args], cwd=repo, capture_output=True, text=True, check=False)

    try:
        head = git("rev-parse", "HEAD")
        if head.returncode != 0:
            return None, False
        return head.stdout.strip(), bool(git("status", "--porcelain").stdout.strip())
    except OSError:  # no git on this machine
        return None, False


def append_session(run_dir: Path | str, argv: list[str], frames: int, aircraft_model: str | None = None) -> dict:
    """Record one training session of the run in ``run_dir``, on the aircraft whose fingerprint is
    ``aircraft_model`` (the paper's when None); returns the record."""
    commit, dirty = git_commit()
    record = {"started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "command": shlex.join(argv),
              "commit": commit, "dirty": dirty, "aircraft_model": aircraft_model or aircraft.model_fingerprint(),
              "frames_at_start": int(frames), "cpu_cores": available_cores()}
    with (Path(run_dir) / SESSIONS_FILE).open("a") as fh:
        fh.write(json.dumps(record) + "\n")
    return record


def read_sessions(run_dir: Path | str) -> list[dict]:
    """The run's session records, oldest first ([] for a run that has none)."""
    path = Path(run_dir) / SESSIONS_FILE
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def training_wall_clock(run_dir: Path | str, frames: int) -> dict:
    """Training wall-clock (s, over all sessions) from the run's ``progress.csv``: at the first row
    with at least ``frames`` steps (None if the run never got there), and at its last row."""
    path = Path(run_dir) / "progress.csv"
    rows = read_progress(path)[0] if path.exists() else []
    if not rows:
        raise ValueError(f"{path} is missing or has no rows: the run's wall-clock is unknown")
    at = [float(r["wall_s"]) for r in rows if int(r["frames"]) >= frames]
    return {"to_policy_s": at[0] if at else None, "whole_run_s": float(rows[-1]["wall_s"]),
            "frames": int(rows[-1]["frames"])}


def trained_aircraft_model(policy_path: Path | str) -> str | None:
    """Fingerprint of the aircraft model a policy file was trained on (``aircraft.model_fingerprint``):
    from the record beside a shipped policy, or from the sessions of the run folder it sits in;
    None when neither names one."""
    path = Path(policy_path)
    record = path.with_suffix(".json")
    if record.exists():
        return json.loads(record.read_text()).get("aircraft_model")
    models = {s.get("aircraft_model") for s in read_sessions(path.parent)}
    return models.pop() if len(models) == 1 else None
