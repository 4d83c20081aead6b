"""Make the suite independent of whatever else runs on the machine, and hold what several test
files share.

pytest keeps only the last three numbered temporary folders (``/tmp/pytest-of-USER/pytest-N``)
and deletes older ones when a session starts, so with several suites running at once one could
delete another's folders mid-run. Each session here gets its own temporary root instead, unless
``--basetemp`` is given.

BLAS runs on one thread: the trim's least-squares steps are tiny, and a multi-threaded BLAS on
an oversubscribed machine only adds a source of run-to-run difference.

Shared fixtures:

| fixture | gives |
|---|---|
| ``tiny_config`` | ``tiny_config(total_frames=192, seed=3)``: a ``TrainConfig`` that trains in seconds |
| ``tiny_args`` | ``tiny_args(total_frames=96, seed=3)``: the same settings as command-line options of ``scripts/train_torchrl.py`` |
| ``load_script`` | ``load_script("evaluate")``: a script under ``scripts/`` imported as a module, to call its functions |
| ``small_aircraft``, ``survey_aircraft`` | the JSBSim root an example aircraft is built into, once a session |
| ``untrained_trainer`` | ``untrained_trainer(run_dir, seed=1, task=None)``: a ``Trainer`` with freshly initialised networks of the default size |
| ``untrained_policy`` | ``untrained_policy(path, seed=1, task=None)``: the policy file such a trainer writes |
| ``untrained_run`` | ``untrained_run(root, name, seed)``: a run folder with such a policy (the paper's task: no trims) and a progress log |
"""

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import importlib.util  # after the thread settings, before anything imports numpy
import shutil
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "scripts"

# The tiny training run, as ``group.name`` settings of ``TrainConfig`` (the seed and the length apart).
TINY_SETTINGS = {
    "env.num_envs": 4,
    "collector.frames_per_batch": 32,
    "collector.init_random_frames": 64,
    "buffer.capacity": 5000,
    "buffer.batch_size": 16,
    "network.lstm_hidden": 8,
    "network.mlp_hidden": 16,
    "log.log_every_frames": 32,
    "log.eval_every_frames": 96,
    "log.eval_episodes": 1,
    "log.checkpoint_every_frames": 96,
    "log.progress": False,
}


def pytest_configure(config):
    if config.option.basetemp is None and not hasattr(config, "workerinput"):
        config.option.basetemp = tempfile.mkdtemp(prefix="solar-uav-tests-")
        config._solar_uav_basetemp = config.option.basetemp


def pytest_unconfigure(config):
    root = getattr(config, "_solar_uav_basetemp", None)
    if root:
        shutil.rmtree(root, ignore_errors=True)


def make_tiny_config(total_frames: int = 192, seed: int = 3):
    """``TINY_SETTINGS`` as a ``TrainConfig`` (each call a new one, free to change)."""
    from training.config import TrainConfig

    c = TrainConfig(seed=seed)
    c.collector.total_frames = total_frames
    for key, value in TINY_SETTINGS.items():
        group, name = key.split(".")
        setattr(getattr(c, group), name, value)
    return c


def make_tiny_args(total_frames: int | None = 96, seed: int | None = 3) -> list[str]:
    """``TINY_SETTINGS`` as options of ``scripts/train_torchrl.py``; ``None`` leaves that option out."""
    args = [] if seed is None else ["--seed", str(seed)]
    if total_frames is not None:
        args += ["--collector.total_frames", str(total_frames)]
    for key, value in TINY_SETTINGS.items():
        args += [f"--{key}", str(value).lower() if isinstance(value, bool) else str(value)]
    return args


def import_script(name: str):
    """``scripts/<name>.py`` imported as a module (its ``main`` is not run)."""
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def make_untrained_trainer(run_dir: Path, seed: int = 1, task: str | None = None):
    """A trainer with freshly initialised networks of the default size (task version ``task``; the
    latest when None) that trains nothing: one aircraft, a replay buffer of ten."""
    from training.config import TrainConfig
    from training.trainer import Trainer

    c = TrainConfig(seed=seed)
    c.env.num_envs, c.buffer.capacity, c.log.progress = 1, 10, False
    if task is not None:
        c.env.task = task
    return Trainer(c, run_dir)


def write_untrained_policy(path: Path, seed: int = 1, task: str | None = None, trainer_dir: Path | None = None) -> Path:
    """The policy file ``make_untrained_trainer`` writes; its run folder is ``trainer_dir`` (beside
    the policy file when None)."""
    path = Path(path)
    trainer = make_untrained_trainer(trainer_dir or path.parent / f"{path.stem}_run", seed, task)
    trainer.save_policy(path, {"return_norm": 0.0})
    return path


def write_untrained_run(root: Path, name: str, seed: int) -> Path:
    """A run folder ``root/name`` (the trainer's) holding an untrained policy of the paper's task
    (SolarUAVAttitude-v0: the network alone, the quickest to fly) and a progress log of two rows."""
    run = Path(root) / name
    write_untrained_policy(run / "best_policy.pt", seed, task="SolarUAVAttitude-v0", trainer_dir=run)
    (run / "progress.csv").write_text("frames,wall_s\n0,0.5\n0,12.0\n")
    return run


@pytest.fixture(scope="session")
def tiny_config():
    return make_tiny_config


@pytest.fixture(scope="session")
def tiny_args():
    return make_tiny_args


def _built(tmp_path_factory, description: str) -> Path:
    pytest.importorskip("aerosandbox")
    root = tmp_path_factory.mktemp(description.removesuffix(".toml"))
    assert import_script("build_aircraft").main([str(ROOT / "aircraft" / description), "--out", str(root)]) == 0
    return root


@pytest.fixture(scope="session")
def small_aircraft(tmp_path_factory):
    """The JSBSim root the small example (``aircraft/small_solar_uav.toml``) is built into, once
    for the session (about 45 s: analysis, JSBSim files, classical controllers, survey)."""
    return _built(tmp_path_factory, "small_solar_uav.toml")


@pytest.fixture(scope="session")
def survey_aircraft(tmp_path_factory):
    """The JSBSim root the survey UAV example (``aircraft/survey_uav.toml``: one propeller, a solved
    tail incidence) is built into, once for the session (about 60 s)."""
    return _built(tmp_path_factory, "survey_uav.toml")


@pytest.fixture(scope="session")
def load_script():
    return import_script


@pytest.fixture(scope="session")
def untrained_trainer():
    return make_untrained_trainer


@pytest.fixture(scope="session")
def untrained_policy():
    return write_untrained_policy


@pytest.fixture(scope="session")
def untrained_run():
    return write_untrained_run
