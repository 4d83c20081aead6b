"""Typed training configuration with command-line overrides.

Every field has a default and a one-line help; ``TrainConfig.add_arguments`` turns them into
``--group.field value`` options (``--help`` lists them), and the full configuration is written as
JSON with each run. What the policy is trained on and flies with (observation, reward, trims,
disturbance ranges) is the task version ``env.task`` (``jsbsim_env.task.versions``); the settings
here are the learning algorithm's and the run's. The paper's values, where it gives them, are in
docs/paper.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from dataclasses import dataclass, field, fields
from typing import Any, get_args, get_origin, get_type_hints

from jsbsim_env.task.versions import LATEST, task_version


def _f(default, help: str):
    """A dataclass field with a help line."""
    return field(default=default, metadata={"help": help})


@dataclass
class EnvSettings:
    task: str = _f(LATEST, "task version trained on and flown with (jsbsim_env.task.versions): "
                           "SolarUAVAttitude-v0 is the paper's, SolarUAVAttitude-v1 the shipped controller's")
    num_envs: int = _f(8, "aircraft simulated side by side in one process")
    disturbances: bool = _f(True, "the task's delay, noise, random interval, randomisation and turbulence (false: "
                                  "ideal sensors and actuators, for checks)")


@dataclass
class CollectorSettings:
    total_frames: int = _f(140_000, "environment steps to train for")
    frames_per_batch: int = _f(64, "environment steps collected between update rounds")
    init_random_frames: int = _f(5_000, "steps with uniformly random actions before learning starts (rounded up "
                                        "to whole batches)")


@dataclass
class BufferSettings:
    capacity: int = _f(1_000_000, "replay capacity in transitions")
    batch_size: int = _f(256, "transitions per gradient step")
    relabel_fraction: float = _f(0.5, "share of each batch given goals near the state reached, with the reward "
                                      "recomputed (training.relabel; 0: none)")


@dataclass
class OptimSettings:
    lr: float = _f(3e-4, "Adam learning rate of actor and critics")
    gamma: float = _f(0.99, "discount")
    tau: float = _f(0.005, "soft target update rate per gradient step")
    alpha: float = _f(0.2, "entropy temperature: the initial one with auto_alpha, else fixed")
    auto_alpha: bool = _f(True, "tune the temperature towards target_entropy (SAC v2); false fixes it at alpha")
    target_entropy: float = _f(-4.0, "policy entropy the tuned temperature aims at (SAC v2: minus the action size)")
    updates_per_step: float = _f(0.25, "gradient steps per environment step")


@dataclass
class NetworkSettings:
    lstm_hidden: int = _f(64, "LSTM hidden units of the actor and of each critic")
    mlp_hidden: int = _f(256, "units of each of the two fully connected layers")


@dataclass
class CapsSettings:
    kappa_spatial: float = _f(0.5, "CAPS spatial smoothness weight")
    kappa_temporal: float = _f(0.25, "CAPS temporal smoothness weight")
    sigma_spatial: float = _f(0.05, "std of the observation perturbation for the spatial term (scaled units)")
    batch_size: int = _f(64, "replay samples (of each update's batch) the CAPS terms are averaged over")
    action_weights: list[float] = field(default_factory=lambda: [1.0, 1.0, 1.0, 1.0], metadata={
        "help": "weight of each action (aileron, elevator, rudder, throttle) in the CAPS differences"})


@dataclass
class LogSettings:
    run_root: str = _f("runs", "folder under which each run gets its own folder")
    log_every_frames: int = _f(1_000, "environment steps between log rows")
    eval_every_frames: int = _f(10_000, "environment steps between deterministic evaluations")
    eval_episodes: int = _f(8, "fixed, seeded evaluation episodes")
    checkpoint_every_frames: int = _f(10_000, "environment steps between checkpoints")
    progress: bool = _f(True, "show a progress bar")


@dataclass
class TrainConfig:
    seed: int = _f(0, "seed of everything: networks, exploration, environments")
    device: str = _f("cpu", "torch device for the networks and updates (cuda when present)")
    threads: int = _f(1, "torch CPU threads for the updates (0: torch's default, all cores). One is fastest "
                         "here: the networks are small, and two OpenMP threads on two busy cores ran 8 times slower")
    env: EnvSettings = field(default_factory=EnvSettings)
    collector: CollectorSettings = field(default_factory=CollectorSettings)
    buffer: BufferSettings = field(default_factory=BufferSettings)
    optim: OptimSettings = field(default_factory=OptimSettings)
    network: NetworkSettings = field(default_factory=NetworkSettings)
    caps: CapsSettings = field(default_factory=CapsSettings)
    log: LogSettings = field(default_factory=LogSettings)

    # ------------------------------------------------------------------ (de)serialisation
    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, sort_keys=True)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainConfig:
        """Rebuild a configuration. A setting this version does not have, or a task version it does
        not have, is an error that names it: the configuration is from another version of the
        package, and only that version trains as it did."""
        kwargs = {}
        hints = get_type_hints(cls)
        for f in fields(cls):
            if f.name not in data:
                continue
            value = data[f.name]
            sub = hints[f.name]
            if dataclasses.is_dataclass(sub):
                unknown = set(value) - {g.name for g in fields(sub)}
                if unknown:
                    raise ValueError(f"settings {', '.join(f'{f.name}.{u}' for u in sorted(unknown))} do not exist in "
                                     "this version of the package: the configuration is from another version")
                value = sub(**value)
            kwargs[f.name] = value
        unknown = set(data) - {f.name for f in fields(cls)}
        if unknown:
            raise ValueError(f"settings {', '.join(sorted(unknown))} do not exist in this version of the package: "
                             "the configuration is from another version")
        config = cls(**kwargs)
        task_version(config.env.task)  # a clear error for a version this package does not have
        return config

    # ------------------------------------------------------------------ command line
    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        """One ``--name`` or ``--group.name`` option per field."""
        hints = get_type_hints(cls)
        for f in fields(cls):
            sub = hints[f.name]
            if dataclasses.is_dataclass(sub):
                sub_hints = get_type_hints(sub)
                group = parser.add_argument_group(f.name)
                for g in fields(sub):
                    _add_option(group, f"{f.name}.{g.name}", sub_hints[g.name], g)
            else:
                _add_option(parser, f.name, sub, f)

    @classmethod
    def from_namespace(cls, ns: argparse.Namespace, base: TrainConfig | None = None) -> TrainConfig:
        """The defaults (or ``base``) with every option given on the command line applied."""
        data = (base or cls()).to_dict()
        for key, value in vars(ns).items():
            if value is None or not key.startswith("cfg:"):
                continue
            path = key[4:].split(".")
            target = data
            for part in path[:-1]:
                target = target[part]
            target[path[-1]] = value
        return cls.from_dict(data)


def _parse_bool(text: str) -> bool:
    if text.lower() in ("1", "true", "yes", "on"):
        return True
    if text.lower() in ("0", "false", "no", "off"):
        return False
    raise argparse.ArgumentTypeError(f"expected true or false, got {text!r}")


def _add_option(parser, name: str, typ, f: dataclasses.Field) -> None:
    default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    if get_origin(typ) is list:  # --name 1 0.5 ...: as many values as the default has
        (item,) = get_args(typ)
        parser.add_argument(f"--{name}", dest=f"cfg:{name}", type=item, nargs=len(default), default=None,
                            metavar=item.__name__.upper(), help=f"{f.metadata.get('help', '')} (default: {default})")
        return
    kind = _parse_bool if typ is bool else typ
    parser.add_argument(f"--{name}", dest=f"cfg:{name}", type=kind, default=None, metavar=typ.__name__.upper(),
                        help=f"{f.metadata.get('help', '')} (default: {default})")
