"""Typed training configuration with command-line overrides.

Every field has a default and a one-line help; ``TrainConfig.add_arguments`` turns them into
``--group.field value`` options (``--help`` lists them), and the full configuration is written as
JSON with each run. What the policy is trained on and flies with (observation, reward, trims,
disturbance ranges) is the task version ``env.task`` (``jsbsim_env.task.versions``); the settings
here are the learning algorithm's and the run's. The paper's values, where it gives them, are in
docs/paper.md.

Each field declares its allowed values beside its default (``Number``, ``Numbers``, ``Text``,
``Flag``, ``TaskName``, ``Device``), and ``TrainConfig.validate`` checks every one of them, with
their types, wherever a configuration is made (the constructor, ``from_dict``, ``from_namespace``;
the trainer checks again). A setting without its allowed values is refused when this module is
imported, so none can be added without one.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import re
from dataclasses import dataclass, field, fields
from typing import Any, get_args, get_origin, get_type_hints

from aircraft import AIRCRAFT_NAME, load_aircraft
from jsbsim_env.control.teacher import TEACHERS
from jsbsim_env.task.versions import LATEST, task_version

SEED_MAX = 2**64 - 1  # the largest seed torch takes
# jsbsim_env.control.network.ENCODERS, spelled out: that module loads torch, which a configuration
# (and a script's --help) need not wait for.
ENCODERS = ("lstm", "gru", "mlp")


# ---------------------------------------------------------------------- allowed values
class Allowed:
    """The values a setting may take. ``problem(name, value)`` is None for one of them; otherwise the
    error names the setting, ``text`` and the value."""

    text = ""

    def admits(self, value) -> bool:
        raise NotImplementedError

    def problem(self, name: str, value) -> str | None:
        return None if self.admits(value) else f"{name} must be {self.text}, got {value!r}"


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class Number(Allowed):
    """An integer (``integer``) or a finite number between ``low`` and ``high`` (None: unbounded),
    each end included unless ``low_open`` / ``high_open``."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    integer: bool = False

    @property
    def text(self) -> str:
        kind = "an integer" if self.integer else "a finite number"
        if self.low is not None and self.high is not None:
            return (f"{kind} in {'(' if self.low_open else '['}{_show(self.low)}, {_show(self.high)}"
                    f"{')' if self.high_open else ']'}")
        if self.low is not None:
            return f"{kind} {'>' if self.low_open else '>='} {_show(self.low)}"
        if self.high is not None:
            return f"{kind} {'<' if self.high_open else '<='} {_show(self.high)}"
        return kind

    def admits(self, value) -> bool:
        if self.integer:
            if not isinstance(value, int) or isinstance(value, bool):
                return False
        elif not _is_number(value) or not math.isfinite(value):
            return False
        if self.low is not None and (value <= self.low if self.low_open else value < self.low):
            return False
        return not (self.high is not None and (value >= self.high if self.high_open else value > self.high))


def _show(bound: float) -> str:
    return str(int(bound)) if float(bound).is_integer() else repr(bound)


@dataclass(frozen=True)
class Numbers(Allowed):
    """A list of ``count`` values, each allowed by ``each``."""

    count: int
    each: Number

    @property
    def text(self) -> str:
        return f"{self.count} numbers, each {self.each.text}"

    def admits(self, value) -> bool:
        return isinstance(value, list) and len(value) == self.count and all(self.each.admits(v) for v in value)


@dataclass(frozen=True)
class Flag(Allowed):
    text: str = "true or false"

    def admits(self, value) -> bool:
        return isinstance(value, bool)


@dataclass(frozen=True)
class Text(Allowed):
    """A string that is not empty (and has no NUL, which no path can hold)."""

    text: str = "a text that is not empty"

    def admits(self, value) -> bool:
        return isinstance(value, str) and value != "" and "\0" not in value


@dataclass(frozen=True)
class Choice(Allowed):
    """One of ``options`` (strings)."""

    options: tuple[str, ...]

    @property
    def text(self) -> str:
        return "one of " + ", ".join(option or '"" (none)' for option in self.options)

    def admits(self, value) -> bool:
        return isinstance(value, str) and value in self.options


@dataclass(frozen=True)
class _LookedUp(Allowed):
    """A text that ``lookup`` finds; where it does not, its error (a ``ValueError`` that says what
    the value is instead), naming the setting."""

    def admits(self, value) -> bool:
        return isinstance(value, str)

    def lookup(self, value: str) -> None:
        raise NotImplementedError

    def problem(self, name: str, value) -> str | None:
        if not self.admits(value):
            return super().problem(name, value)
        try:
            self.lookup(value)
        except ValueError as err:
            return f"{name}: {err}"
        return None


@dataclass(frozen=True)
class TaskName(_LookedUp):
    """A task version this package has (``task_version``'s error lists them)."""

    text: str = "the name of a task version (jsbsim_env.task.versions)"

    def lookup(self, value: str) -> None:
        task_version(value)


@dataclass(frozen=True)
class AircraftName(_LookedUp):
    """An aircraft ``aircraft.load_aircraft`` finds (its ``AircraftError`` says what the value is instead)."""

    text: str = "a packaged aircraft's name or a built aircraft's folder (scripts/build_aircraft.py --out)"

    def admits(self, value) -> bool:
        return isinstance(value, str) and value != "" and "\0" not in value

    def lookup(self, value: str) -> None:
        load_aircraft(value)


_DEVICE = re.compile(r"cpu|cuda(:[0-9]+)?")


@dataclass(frozen=True)
class Device(Allowed):
    """A torch device written as this package trains on them (whether it is present here is
    ``check_device``'s to say, where training starts: a configuration read elsewhere may name a
    device this machine lacks)."""

    text: str = "cpu, cuda or cuda:N"

    def admits(self, value) -> bool:
        return isinstance(value, str) and _DEVICE.fullmatch(value) is not None


def _f(default, help: str, allowed: Allowed, short: str | None = None):
    """A dataclass field with a help line and its allowed values; ``short``: a second option name
    (``--aircraft`` for ``--env.aircraft``, as every command takes it)."""
    return field(default=default, metadata={"help": help, "allowed": allowed, "short": short})


POSITIVE_INT = Number(1, integer=True)
# Upper bounds of the settings that size what a run holds in memory. The paper's networks have 64
# and 256 units and the shipped runs 8 aircraft; 16 times the paper's largest layer is already a
# network of 200 million weights. A run is also refused where the memory it needs (replay buffer,
# aircraft, networks: ``training.trainer.memory_needed``) exceeds what the machine has free.
MAX_UNITS = 4096
MAX_AIRCRAFT = 4096
MAX_CAPACITY = 10**9
COUNT = Number(0, integer=True)  # zero allowed
POSITIVE = Number(0, low_open=True)
NON_NEGATIVE = Number(0)
FRACTION = Number(0, 1)


@dataclass
class EnvSettings:
    task: str = _f(LATEST, "task version trained on and flown with (jsbsim_env.task.versions): "
                           "SolarUAVAttitude-v0 is the paper's, SolarUAVAttitude-v1 the shipped controller's", TaskName())
    aircraft: str = _f(AIRCRAFT_NAME, "the aircraft trained on: a packaged aircraft's name (the paper's solar_uav) or "
                                      "a folder built by scripts/build_aircraft.py --out", AircraftName(), short="aircraft")
    num_envs: int = _f(8, "aircraft simulated side by side in one process (also bounded by the machine's memory)",
                       Number(1, MAX_AIRCRAFT, integer=True))
    disturbances: bool = _f(True, "the task's delay, noise, random interval, randomisation and turbulence (false: "
                                  "ideal sensors and actuators, for checks)", Flag())


@dataclass
class CollectorSettings:
    total_frames: int = _f(140_000, "environment steps to train for", POSITIVE_INT)
    frames_per_batch: int = _f(64, "environment steps collected between update rounds", POSITIVE_INT)
    init_random_frames: int = _f(5_000, "steps with uniformly random actions before learning starts (rounded up "
                                        "to whole batches)", COUNT)


@dataclass
class BufferSettings:
    capacity: int = _f(1_000_000, "replay capacity in transitions (also bounded by the machine's memory)",
                       Number(1, MAX_CAPACITY, integer=True))
    batch_size: int = _f(256, "transitions per gradient step", POSITIVE_INT)
    relabel_fraction: float = _f(0.5, "share of each batch given goals near the state reached, with the reward "
                                      "recomputed (training.relabel; 0: none)", FRACTION)


@dataclass
class OptimSettings:
    lr: float = _f(3e-4, "Adam learning rate of actor and critics", POSITIVE)
    # 1 would sum rewards without end: the critics' targets have no bound.
    gamma: float = _f(0.99, "discount", Number(0, 1, high_open=True))
    tau: float = _f(0.005, "soft target update rate per gradient step", Number(0, 1, low_open=True))
    alpha: float = _f(0.2, "entropy temperature: the initial one with auto_alpha, else fixed", POSITIVE)
    auto_alpha: bool = _f(True, "tune the temperature towards target_entropy (SAC v2); false fixes it at alpha", Flag())
    target_entropy: float = _f(-4.0, "policy entropy the tuned temperature aims at (SAC v2: minus the action size)",
                               Number())
    updates_per_step: float = _f(0.25, "gradient steps per environment step", POSITIVE)


@dataclass
class NetworkSettings:
    encoder: str = _f("lstm", "the actor's and each critic's encoder of the observation window: lstm (the paper's), "
                              "gru, or mlp (the window flattened through one ReLU layer)", Choice(ENCODERS))
    lstm_hidden: int = _f(64, "units of the encoder (LSTM, GRU or window MLP) of the actor and of each critic",
                          Number(1, MAX_UNITS, integer=True))
    mlp_hidden: int = _f(256, "units of each of the two fully connected layers", Number(1, MAX_UNITS, integer=True))
    asymmetric_critic: bool = _f(False, "the critics also read what the aircraft cannot measure (true state, "
                                        "turbulence, the episode's coefficients, delay, trims); the actor never does",
                                 Flag())


@dataclass
class CapsSettings:
    kappa_spatial: float = _f(0.5, "CAPS spatial smoothness weight", NON_NEGATIVE)
    kappa_temporal: float = _f(0.25, "CAPS temporal smoothness weight", NON_NEGATIVE)
    sigma_spatial: float = _f(0.05, "std of the observation perturbation for the spatial term (scaled units)",
                              POSITIVE)
    batch_size: int = _f(64, "replay samples (of each update's batch) the CAPS terms are averaged over",
                         POSITIVE_INT)
    action_weights: list[float] = field(default_factory=lambda: [1.0, 1.0, 1.0, 1.0], metadata={
        "help": "weight of each action (aileron, elevator, rudder, throttle) in the CAPS differences",
        "allowed": Numbers(4, NON_NEGATIVE)})


@dataclass
class DistillSettings:
    teacher: str = _f("", "an LQI to start the network from (lqi, lqi_tuned, lqi_robust, lqi_stressed; empty: none, SAC from random "
                          "steps): distilled by DAgger, its critics warmed, then SAC with the teacher's flights in "
                          "each batch (training.trainer); its steps take the place of the random ones",
                      Choice(("", *TEACHERS)))
    dagger_frames: int = _f(20_000, "environment steps of the distillation, within collector.total_frames: the "
                                    "teacher flies every step at first, the network more and more, to all of them",
                            POSITIVE_INT)
    updates_per_step: float = _f(1.0, "imitation gradient steps per environment step of the distillation", POSITIVE)
    critic_warmup_updates: int = _f(5_000, "critic-only gradient steps after the distillation, before SAC moves "
                                           "the network", COUNT)
    offline_share: float = _f(0.5, "share of each SAC batch drawn from the steps the teacher flew (as Ball et al. "
                                   "2023 keep offline data; 0: none)", FRACTION)
    bc_weight: float = _f(0.4, "weight of the teacher's action in SAC's actor loss, times the batch's mean |Q| (TD3+BC's "
                               "normalisation, Fujimoto and Gu 2021, whose alpha 2.5 is 0.4 here), on the steps whose "
                               "goals are as flown; 0: none", NON_NEGATIVE)
    start_std: float = _f(0.075, "pre-tanh standard deviation of the distilled network's exploration (0.075 of "
                                 "the travel: the residual's 0.3 of a quarter of it)", Number(0.02, 1))


@dataclass
class LogSettings:
    run_root: str = _f("runs", "folder under which each run gets its own folder", Text())
    log_every_frames: int = _f(1_000, "environment steps between log rows", POSITIVE_INT)
    eval_every_frames: int = _f(10_000, "environment steps between deterministic evaluations", POSITIVE_INT)
    eval_episodes: int = _f(8, "fixed, seeded evaluation episodes, flown side by side",
                            Number(1, MAX_AIRCRAFT, integer=True))
    checkpoint_every_frames: int = _f(10_000, "environment steps between checkpoints", POSITIVE_INT)
    keep_evaluated: bool = _f(True, "keep every evaluated policy in the run's evaluated/ folder (about 0.4 MB each), "
                                    "for a choice among them on held-out flights (scripts/heldout.py --checkpoints)",
                              Flag())
    progress: bool = _f(True, "show a progress bar", Flag())


@dataclass
class TrainConfig:
    seed: int = _f(0, "seed of everything: networks, exploration, environments", Number(0, SEED_MAX, integer=True))
    device: str = _f("cpu", "torch device for the networks and updates: cpu, cuda or cuda:N", Device())
    threads: int = _f(1, "torch CPU threads for the updates (0: torch's default, all cores). One is fastest "
                         "here: the networks are small, and two OpenMP threads on two busy cores ran 8 times slower",
                      COUNT)
    env: EnvSettings = field(default_factory=EnvSettings)
    collector: CollectorSettings = field(default_factory=CollectorSettings)
    buffer: BufferSettings = field(default_factory=BufferSettings)
    optim: OptimSettings = field(default_factory=OptimSettings)
    network: NetworkSettings = field(default_factory=NetworkSettings)
    caps: CapsSettings = field(default_factory=CapsSettings)
    distill: DistillSettings = field(default_factory=DistillSettings)
    log: LogSettings = field(default_factory=LogSettings)

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Check every setting's type and range (each field's ``allowed``) and the settings that
        depend on each other; raises ``ValueError`` with one line naming the first setting that is
        not allowed and what it may be."""
        for name, value, allowed in _settings(self):
            problem = allowed.problem(name, value)
            if problem:
                raise ValueError(problem)
        c = self.collector
        if c.frames_per_batch < self.env.num_envs:
            raise ValueError(f"collector.frames_per_batch ({c.frames_per_batch}) must be at least env.num_envs "
                             f"({self.env.num_envs}): each batch takes a step of every aircraft")
        d = self.distill
        if d.teacher:
            if task_version(self.env.task).flight_stack.residual_on:
                raise ValueError(f"distill.teacher ({d.teacher}) distils an LQI into a network that flies alone; "
                                 f"env.task {self.env.task} is a residual on an LQI: use a task version without one")
            if c.total_frames <= d.dagger_frames:
                raise ValueError(f"collector.total_frames ({c.total_frames}) must exceed distill.dagger_frames "
                                 f"({d.dagger_frames}): the run would only distil and never learn by SAC")
        elif c.total_frames <= c.init_random_frames:
            raise ValueError(f"collector.total_frames ({c.total_frames}) must exceed collector.init_random_frames "
                             f"({c.init_random_frames}): the run would only take random steps and learn nothing")

    # ------------------------------------------------------------------ (de)serialisation
    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, sort_keys=True)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainConfig:
        """Rebuild a configuration. A setting this version does not have, or a task version it does
        not have, is an error that names it: the configuration is from another version of the
        package, and only that version trains as it did. So is a setting of the wrong type or out
        of its range (``validate``)."""
        if not isinstance(data, dict):
            # ValueError as every other configuration error, for the callers to catch as one.
            raise ValueError(f"a configuration must be a JSON object of settings, got {type(data).__name__}")  # noqa: TRY004
        kwargs = {}
        hints = get_type_hints(cls)
        for f in fields(cls):
            if f.name not in data:
                continue
            value = data[f.name]
            sub = hints[f.name]
            if dataclasses.is_dataclass(sub):
                if not isinstance(value, dict):
                    raise ValueError(f"{f.name} must be a group of settings (a JSON object), got {value!r}")
                unknown = set(value) - {g.name for g in fields(sub)}
                if unknown:
                    raise ValueError(f"settings {', '.join(f'{f.name}.{u}' for u in sorted(unknown))} do not exist in "
                                     "this version of the package: the configuration is from another version")
                value = sub(**{k: list(v) if isinstance(v, list) else v for k, v in value.items()})
            kwargs[f.name] = value
        unknown = set(data) - {f.name for f in fields(cls)}
        if unknown:
            raise ValueError(f"settings {', '.join(sorted(unknown))} do not exist in this version of the package: "
                             "the configuration is from another version")
        return cls(**kwargs)  # validated (``__post_init__``)

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


def _settings(config: TrainConfig):
    """(``group.name``, value, allowed) of every setting."""
    hints = get_type_hints(TrainConfig)
    for f in fields(TrainConfig):
        value = getattr(config, f.name)
        group = hints[f.name]
        if not dataclasses.is_dataclass(group):
            yield f.name, value, f.metadata["allowed"]
        elif not isinstance(value, group):
            raise ValueError(f"{f.name} must be a group of settings ({group.__name__}), got {value!r}")
        else:
            for g in fields(group):
                yield f"{f.name}.{g.name}", getattr(value, g.name), g.metadata["allowed"]


def allowed_values() -> dict[str, str]:
    """Each setting (``group.name``) with the values it may take, in words."""
    return {name: allowed.text for name, _, allowed in _settings(TrainConfig())}


def _require_allowed_values() -> None:
    """Every setting declares its allowed values: a new one without them fails on import."""
    hints = get_type_hints(TrainConfig)
    for f in fields(TrainConfig):
        group = hints[f.name]
        for g in fields(group) if dataclasses.is_dataclass(group) else (f,):
            if not isinstance(g.metadata.get("allowed"), Allowed):
                raise TypeError(f"training.config: the setting {g.name!r} declares no allowed values (metadata "
                                "'allowed'): give it its range beside its default")


def check_device(device: str) -> None:
    """Raise ``ValueError`` (one line) unless ``device`` is a torch device present on this machine."""
    if device == "cpu":
        return
    import torch

    try:
        parsed = torch.device(device)
    except (RuntimeError, ValueError):
        raise ValueError(f"device must be {Device.text}, got {device!r}") from None
    if parsed.type != "cuda":
        raise ValueError(f"device must be {Device.text}, got {device!r}")
    count = torch.cuda.device_count() if torch.cuda.is_available() else 0
    if count == 0 or (parsed.index or 0) >= count:
        here = f"{count} CUDA device{'s' if count != 1 else ''} here" if count else "torch sees no CUDA device here"
        others = "" if not count else " or cuda:0" if count == 1 else f" or one of cuda:0 to cuda:{count - 1}"
        raise ValueError(f"device {device} is not available ({here}): use --device cpu{others}")


def check_run_name(name: str) -> str:
    """``name`` when it is one plain folder name (the run goes to ``log.run_root/name``): not empty,
    not '.' or '..', with no path separator; ``ValueError`` otherwise."""
    seps = {"/", os.sep} | ({os.altsep} if os.altsep else set())
    if not name or name in (".", "..") or any(sep in name for sep in seps) or "\0" in name:
        raise ValueError(f"--run-name must be a plain folder name (not empty, '.' or '..', no '/'), got {name!r}")
    return name


def _parse_bool(text: str) -> bool:
    """``true`` or ``false``, as ``--help`` says (``Flag``): nothing else, so that a slip such as
    ``no`` or ``0`` is refused rather than read one way or the other."""
    if text == "true":
        return True
    if text == "false":
        return False
    raise argparse.ArgumentTypeError(f"must be true or false, got {text!r}")


def _add_option(parser, name: str, typ, f: dataclasses.Field) -> None:
    default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    if get_origin(typ) is list:  # --name 1 0.5 ...: as many values as the default has
        (item,) = get_args(typ)
        parser.add_argument(f"--{name}", dest=f"cfg:{name}", type=item, nargs=len(default), default=None,
                            metavar=item.__name__.upper(), help=_help(f, default))
        return
    kind = _parse_bool if typ is bool else typ
    names = [f"--{name}"] + ([f"--{f.metadata['short']}"] if f.metadata.get("short") else [])
    parser.add_argument(*names, dest=f"cfg:{name}", type=kind, default=None, metavar=typ.__name__.upper(),
                        help=_help(f, default))


def _help(f: dataclasses.Field, default) -> str:
    """The option's help line: what it sets, its default and its allowed values (``%`` doubled for argparse)."""
    text = f"{f.metadata.get('help', '')} (default: {default}; {f.metadata['allowed'].text})"
    return text.replace("%", "%%")


_require_allowed_values()
