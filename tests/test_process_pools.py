"""The package's process pools (``training.workers``): a pool started after torch has run its
OpenMP threads finishes (a forked worker inherited a dead thread pool and waited for it forever),
each worker runs one torch thread, and Ctrl-C stops the command and its workers in one line.

The commands run in their own processes here with ``OMP_NUM_THREADS=2``, as on a fresh 2-core
machine: with the suite's own setting of 1 thread (conftest.py) no pool would deadlock."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest
from conftest import ROOT, SCRIPTS

from training.workers import THREAD_VARIABLES, process_pool

BOUND_S = 240.0  # each command flies for about 10 s here; a deadlock never ends


def _two_thread_env() -> dict:
    return {**os.environ, **{name: "2" for name in THREAD_VARIABLES}}


def _run_after_torch(script: str, args: list[str]) -> subprocess.CompletedProcess:
    """``scripts/<script>.py args`` called in a process that ran a parallel torch operation on 2
    threads first; killed (and the test failed) past ``BOUND_S``."""
    program = textwrap.dedent(f"""
        import sys
        import torch
        torch.set_num_threads(2)
        assert bool(torch.isfinite(torch.randn(1 << 22)).all())  # OpenMP's pool of 2 threads is up
        sys.path.insert(0, {str(SCRIPTS)!r})
        import {script}
        sys.exit({script}.main({args!r}))
    """)
    proc = subprocess.Popen([sys.executable, "-c", program], cwd=ROOT, env=_two_thread_env(), text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=BOUND_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"{script} with 2 workers did not finish in {BOUND_S:.0f} s (a deadlocked worker)")
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def test_a_two_worker_benchmark_after_torch_finishes(tmp_path):
    done = _run_after_torch("benchmark", ["--controllers", "policy,pid", "--families", "turbulence", "--episodes", "2",
                                          "--quick", "--workers", "2", "--no-progress", "--out", str(tmp_path)])
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "benchmark.json").is_file()


def test_a_two_worker_sweep_after_torch_finishes(tmp_path):
    done = _run_after_torch("sweep", ["--axis", "delay_ms=0,100", "--controllers", "policy", "--episodes", "1",
                                      "--workers", "2", "--out", str(tmp_path)])
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "sweep.json").is_file()


def _torch_threads(_job: int) -> tuple[int, str | None]:
    import torch

    return torch.get_num_threads(), os.environ.get("OMP_NUM_THREADS")


def test_each_worker_runs_one_torch_thread_and_the_parent_keeps_its_settings(monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    with process_pool(2) as pool:
        seen = list(pool.map(_torch_threads, range(4)))
    assert seen == [(1, "1")] * 4
    assert os.environ["OMP_NUM_THREADS"] == "2"


def _group_pids(pgid: int) -> set[int]:
    out = subprocess.run(["ps", "-o", "pid=", "-g", str(pgid)], capture_output=True, text=True, check=False).stdout
    return {int(p) for p in out.split()}


# Runs the command with Ctrl-C's default action, as a terminal's foreground job has it: a suite started
# in the background of a shell without job control (nohup, ``&`` in a script) runs with SIGINT
# ignored, every process it starts inherits that, and Python then never raises KeyboardInterrupt.
# The same process (exec), so that it leads its process group as the command itself would.
AS_IN_A_TERMINAL = ("import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
                    "os.execv(sys.executable, [sys.executable, *sys.argv[1:]])")


@pytest.mark.parametrize("when", ["workers starting", "flights under way"])
def test_ctrl_c_stops_the_benchmark_and_its_workers_in_one_line(when, tmp_path):
    proc = subprocess.Popen([sys.executable, "-c", AS_IN_A_TERMINAL, str(SCRIPTS / "benchmark.py"),
                             "--controllers", "policy,pid", "--families", "turbulence", "--episodes", "10",
                             "--workers", "2", "--no-progress", "--out", str(tmp_path)],
                            cwd=ROOT, env=_two_thread_env(), text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True)
    try:
        # The command, multiprocessing's resource tracker, then the workers: Ctrl-C as the first
        # worker starts (it is still importing), or once both fly.
        processes = 3 if when == "workers starting" else 4
        deadline = time.monotonic() + 120.0
        while len(_group_pids(proc.pid)) < processes and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        if when == "flights under way":
            time.sleep(2.0)
        assert proc.poll() is None, "the benchmark ended before it could be stopped"
        os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the whole process group
        stopped = time.monotonic()
        _, err = proc.communicate(timeout=30)
        took_s = time.monotonic() - stopped
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert took_s < 20.0, took_s  # the workers' SIGTERM grace is 5 s; a loaded machine is slower
    assert err.strip().splitlines() == ["benchmark: stopped by SIGINT (Ctrl-C) before it finished"], err
    deadline = time.monotonic() + 10.0
    while _group_pids(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not _group_pids(proc.pid), "workers outlived the command"
    assert not (tmp_path / "benchmark.json").exists()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent-death signal is Linux's prctl")
def test_workers_end_when_their_parent_is_killed(tmp_path):
    # A parent killed outright (SIGKILL: no clean-up of its own) leaves no worker behind to go on
    # flying or training and hold its run folder.
    code = textwrap.dedent("""
        import time
        from training.workers import process_pool

        def pid_after(seconds):
            import os
            time.sleep(seconds)
            return os.getpid()

        def own_pid(_):
            import os
            return os.getpid()

        if __name__ == "__main__":
            with process_pool(2, jobs=2) as pool:
                pids = sorted(set(pool.map(own_pid, range(8))))
                print(" ".join(map(str, pids)), flush=True)
                list(pool.map(pid_after, [600.0, 600.0]))
    """)
    script = tmp_path / "pool_parent.py"  # a file, so that the spawned workers can import its functions
    script.write_text(code)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    # stderr dropped: the killed parent's resource tracker reports the semaphores it leaves.
    parent = subprocess.Popen([sys.executable, str(script)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                              text=True, env=env)
    try:
        workers = [int(p) for p in parent.stdout.readline().split()]
        assert workers and all(_alive(p) for p in workers)
        parent.kill()
        parent.wait(timeout=30)
        deadline = time.monotonic() + 20.0
        while any(_alive(p) for p in workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(_alive(p) for p in workers), "a worker outlived its killed parent"
    finally:
        parent.kill()


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, ended but not yet reaped by init, does not)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False
