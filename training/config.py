"""Typed training configuration with command-line overrides.

Every field has a default (SPEC section 3, except where its help says why not) and a help line;
``TrainConfig.from_args`` turns them into ``--group.field value`` options (``--help`` lists them),
and the full configuration is written as JSON with each run.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
from dataclasses import dataclass, field, fields
from typing import Any, get_args, get_origin, get_type_hints

PRESETS = ("default", "paper")


def _f(default, help: str):
    """A dataclass field with a help line."""
    return field(default=default, metadata={"help": help})


@dataclass
class EnvSettings:
    num_envs: int = _f(8, "aircraft simulated side by side in one process")
    window: int = _f(8, "observation window the networks see (SPEC: 8)")
    disturbances: bool = _f(True, "delay, noise, random interval, randomisation and turbulence (SPEC training setting)")
    error_integral_decay: float = _f(0.0, "per-step decay of the error integrals added to the observation "
                                          "(jsbsim_env.task.ErrorIntegrals; 0: none, as the paper)")
    integral_trim: float = _f(0.5, "integral trim on aileron and elevator at this fraction of the PID's integral "
                                   "gains, learned beside the policy (jsbsim_env.controllers.integral_trim; 0: none, "
                                   "as the paper). Removes the policy's steady attitude error (docs/training.md)")
    # Twice the PID's gains in flight: over the default's three seeds, each flown at 0.5 (as
    # trained), 1, 1.5 and 2 times the PID's integral gains, the held-out flights scored 2 best in
    # every seed, with the turbulent roll falling the most (docs/training.md).
    flight_integral_trim: float = _f(2.0, "integral trim gains (a fraction of the PID's) the policy file records for "
                                          "flight, for a run trained with hidden integral trims; training episodes "
                                          "and the run's own evaluation keep integral_trim (0: integral_trim in "
                                          "flight too; scripts/set_trims.py changes it afterwards)")
    observe_trims: bool = _f(False, "show the integral trims to the policy (a policy that sees them learns to "
                                    "cancel them and they drift to their limits, docs/training.md)")
    trims_in_surfaces: bool = _f(False, "the policy's observed positions of the trimmed surfaces include the integral "
                                        "trims, as measured (False: the present trims taken off, so that hidden trims "
                                        "show only while they move; docs/training.md)")
    rudder_trim_s: float = _f(0.0, "time constant (s) of a rudder trim on sideslip beside the integral trims, at "
                                   "integral_trim times the PID's sideslip gain over it (hidden trims only; 0: none)")
    goal_trim_s: float = _f(20.0, "time constant (s) of the goal trim the policy flies with, recorded in the policy "
                                  "file and applied by PolicyRuntime (jsbsim_env.controllers.goal_trim; training "
                                  "episodes go without: their goals change every 3-10 s; 5 s made the goal wander "
                                  "with the sensor noise, docs/training.md). 0: none")
    # Roll x2, pitch x2 and sideslip x6 put all three attitude penalties at one cap (0.6): over
    # three seeds the turbulent-leg and Table 9 errors fell below the single weights' on nearly
    # every axis (docs/training.md); the aileron's chatter that roll x2 brought went with the
    # aileron's CAPS weight back to full (caps.action_weights).
    sideslip_weight: float = _f(6.0, "training reward's sideslip penalty and its cap times this (1: SPEC Eq. 22; "
                                     "6 puts it at the roll's and pitch's cap, docs/training.md); evaluations keep "
                                     "Eq. 22")
    roll_weight: float = _f(2.0, "training reward's roll penalty and its cap times this (1: SPEC Eq. 22); "
                                 "evaluations keep Eq. 22")
    pitch_weight: float = _f(2.0, "training reward's pitch penalty and its cap times this (1: SPEC Eq. 22); "
                                  "evaluations keep Eq. 22")
    penalty_tail: float = _f(0.1, "training reward: share of each Eq. 22 penalty's slope kept beyond its cap, so that a "
                                  "large error still costs more than a small one (0: SPEC Eq. 22; with external_throttle "
                                  "it taught the policy to follow TECS's pitch, docs/training.md); evaluations keep Eq. 22")
    # From 40 ms: the policy also meets the shorter delays of the routes and the loop bench, and
    # the turbulent-leg roll and pitch fell (docs/training.md).
    delay_ms: list[float] = field(default_factory=lambda: [40.0, 120.0], metadata={
        "help": "range (low high, ms) the training episodes' control delay is drawn from, uniformly (SPEC: 80 120; "
                "every evaluation, the run's own included, keeps its own)"})
    turbulence_sigma_mps: float = _f(0.5, "standard deviation (m/s) of the training episodes' turbulence on each axis "
                                          "(SPEC and every evaluation, the run's own included: 0.5)")
    external_throttle: float = _f(0.3, "share of training episodes whose throttle a speed hold flies instead of the "
                                       "policy and whose EAS goal is the measured EAS, as on a route under TECS "
                                       "(0: none, as the paper)")

    @property
    def flown_integral_trim(self) -> float:
        """The integral trim gains this run's policy files fly with: ``flight_integral_trim``, or
        ``integral_trim`` where that is 0."""
        return self.flight_integral_trim or self.integral_trim


@dataclass
class CollectorSettings:
    # SPEC: converged in about 0.2 M; on the corrected aircraft our runs' evaluation return levels
    # off from about 80k steps (docs/training.md, ablation), and 140k keeps a run within 45 min here.
    total_frames: int = _f(140_000, "environment steps to train for (SPEC: 0.2 M; ours level off by 0.14 M)")
    frames_per_batch: int = _f(64, "environment steps collected between update rounds")
    init_random_frames: int = _f(5_000, "steps with uniformly random actions before learning starts (rounded up "
                                        "to whole batches)")


@dataclass
class BufferSettings:
    capacity: int = _f(1_000_000, "replay capacity in transitions (SPEC: 1e6)")
    batch_size: int = _f(256, "transitions per gradient step (SPEC: 256)")
    relabel_fraction: float = _f(0.5, "share of each batch given goals near the state reached, with the reward "
                                      "recomputed (training.relabel; 0 trains as the paper)")
    relabel_spread: float = _f(2.0, "relabelled goal offset from the state reached, in multiples of each "
                                    "channel's reward saturation error")


@dataclass
class OptimSettings:
    lr: float = _f(3e-4, "Adam learning rate of actor and critics (SPEC: 3e-4)")
    gamma: float = _f(0.99, "discount (SPEC: 0.99)")
    tau: float = _f(0.005, "soft target update rate per gradient step (SPEC: 0.005)")
    alpha: float = _f(0.2, "entropy temperature: the initial one with auto_alpha, else fixed (SPEC: 0.2 fixed)")
    auto_alpha: bool = _f(True, "tune the temperature towards target_entropy (SAC v2); false fixes it at alpha "
                                "as the paper did, which did not learn in our runs (README)")
    target_entropy: float = _f(-4.0, "policy entropy the tuned temperature aims at (SAC v2: minus the action size)")
    recurrent_lr: float = _f(0.0, "Adam learning rate of the LSTM layers of actor and critics (0: lr). RESeL "
                                   "(Luo et al. 2024) trains the recurrent encoder slower than the layers after it")
    updates_per_step: float = _f(0.25, "gradient steps per environment step (SPEC: 1; 0.25 learns faster "
                                       "per hour and per gradient step, README)")
    lr_end_fraction: float = _f(1.0, "learning rates of actor and critics fall linearly from their values at the "
                                     "first update to this fraction of them at collector.total_frames (1: "
                                     "constant, SPEC); the temperature's stays as it is")


@dataclass
class NetworkSettings:
    lstm_hidden: int = _f(64, "LSTM hidden units of the actor and of each critic (SPEC: 64)")
    mlp_hidden: int = _f(256, "units of each of the two fully connected layers (SPEC: 256)")
    initial_std: float = _f(1.0, "the actor's standard deviation (before tanh) at initialisation (TorchRL: 1)")
    critic: str = _f("recurrent", "critics' input: 'recurrent' (the actor's observation window through an LSTM, "
                                  "SPEC) or 'state' (the simulation's true, undelayed state, an MLP; the actor "
                                  "is unchanged)")


@dataclass
class CapsSettings:
    # A quarter of SPEC's weights: over three seeds each, the suite return rose from 0.562 (SPEC's) to
    # 0.596 (half) to 0.629 (a quarter), with the calm-air steady state and the turbulent sideslip
    # better each time and the turbulent roll and pitch better at a quarter (docs/training.md);
    # --preset paper keeps SPEC's 2 and 1.
    kappa_spatial: float = _f(0.5, "CAPS spatial smoothness weight (SPEC: 2; a quarter of it scored best)")
    kappa_temporal: float = _f(0.25, "CAPS temporal smoothness weight (SPEC: 1; a quarter of it scored best)")
    sigma_spatial: float = _f(0.05, "std of the observation perturbation for the spatial term (scaled units)")
    batch_size: int = _f(64, "replay samples (of each update's batch) the CAPS terms are averaged over")
    # Every action at full weight: with the roll penalty doubled (env.roll_weight), half weight on
    # the aileron let two seeds of three chatter it (docs/training.md).
    action_weights: list[float] = field(default_factory=lambda: [1.0, 1.0, 1.0, 1.0], metadata={
        "help": "weight of each action (aileron, elevator, rudder, throttle) in the CAPS differences (all 1: SPEC "
                "and the default; half on the aileron lowered the roll error under a single roll weight, "
                "docs/training.md)"})
    goal_aware: bool = _f(False, "goal-aware CAPS: the temporal term holds the goals across a step and the spatial "
                                 "noise leaves them alone, so that smoothing does not slow the response to a "
                                 "command (False: SPEC's CAPS)")


@dataclass
class LogSettings:
    run_root: str = _f("runs", "folder under which each run gets its own folder")
    log_every_frames: int = _f(1_000, "environment steps between log rows")
    eval_every_frames: int = _f(10_000, "environment steps between deterministic evaluations")
    eval_episodes: int = _f(8, "fixed, seeded evaluation episodes")
    eval_max_steps: int = _f(500, "interactions per evaluation episode")
    checkpoint_every_frames: int = _f(10_000, "environment steps between checkpoints")
    progress: bool = _f(True, "show a progress bar")


# The behaviour of the code before each of these settings existed: what a saved run without the
# setting trained with. The settings added since the first configuration are all here except
# caps.batch_size (before it, CAPS used the whole batch) and optim.target_entropy (before it,
# TorchRL's automatic target, minus the batched action size); a run that old cannot be resumed
# as it began.
LEGACY_VALUES: dict[str, Any] = {
    "env.error_integral_decay": 0.0,
    "env.integral_trim": 0.0,
    "env.flight_integral_trim": 0.0,
    "env.observe_trims": True,
    "env.trims_in_surfaces": True,
    "env.rudder_trim_s": 0.0,
    "env.goal_trim_s": 0.0,
    "env.sideslip_weight": 1.0,
    "env.roll_weight": 1.0,
    "env.pitch_weight": 1.0,
    "env.penalty_tail": 0.0,
    "env.delay_ms": [80.0, 120.0],
    "env.turbulence_sigma_mps": 0.5,
    "env.external_throttle": 0.0,
    "buffer.relabel_fraction": 0.0,
    "optim.auto_alpha": False,
    "optim.recurrent_lr": 0.0,
    "optim.lr_end_fraction": 1.0,
    "network.initial_std": 1.0,
    "network.critic": "recurrent",
    "caps.action_weights": [1.0, 1.0, 1.0, 1.0],
    "caps.goal_aware": False,
}


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

    @classmethod
    def preset(cls, name: str) -> TrainConfig:
        """A named starting configuration: ``"default"`` (this package's) or ``"paper"`` (SPEC
        section 3 as far as this environment allows: a fixed temperature of 0.2, one gradient step
        per environment step, no goal relabelling, no error integrals, integral trim or external
        throttle, Eq. 22's reward, CAPS weights 2 and 1 on every action alike; the observation
        keeps the last action, without which nothing learned, README)."""
        config = cls()
        if name == "paper":
            config.optim.auto_alpha = False
            config.optim.alpha = 0.2
            config.optim.updates_per_step = 1.0
            config.optim.lr_end_fraction = 1.0
            config.buffer.relabel_fraction = 0.0
            config.env.error_integral_decay = 0.0
            config.env.integral_trim = 0.0
            config.env.flight_integral_trim = 0.0
            config.env.rudder_trim_s = 0.0
            config.env.trims_in_surfaces = True
            config.env.goal_trim_s = 0.0
            config.env.sideslip_weight = 1.0
            config.env.roll_weight = 1.0
            config.env.pitch_weight = 1.0
            config.env.penalty_tail = 0.0
            config.env.external_throttle = 0.0
            config.env.turbulence_sigma_mps = 0.5
            config.env.delay_ms = [80.0, 120.0]
            config.caps.kappa_spatial = 2.0
            config.caps.kappa_temporal = 1.0
            config.caps.action_weights = [1.0, 1.0, 1.0, 1.0]
        elif name != "default":
            raise ValueError(f"unknown preset {name!r}: use one of {PRESETS}")
        return config

    # ------------------------------------------------------------------ (de)serialisation
    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, sort_keys=True)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainConfig:
        """Rebuild a configuration; unknown keys are an error (a config from another version).

        A setting missing from ``data`` (a run saved before the setting existed) takes the value
        that reproduces how that run trained (``LEGACY_VALUES``), not the present default, so that
        a resumed old run goes on as it began."""
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
                    raise ValueError(f"unknown settings in {f.name}: {sorted(unknown)}")
                missing = {g.name for g in fields(sub)} - set(value)
                legacy = {name: LEGACY_VALUES[f"{f.name}.{name}"] for name in missing
                          if f"{f.name}.{name}" in LEGACY_VALUES}
                value = sub(**value, **copy.deepcopy(legacy))
            kwargs[f.name] = value
        unknown = set(data) - {f.name for f in fields(cls)}
        if unknown:
            raise ValueError(f"unknown settings: {sorted(unknown)}")
        return cls(**kwargs)

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
