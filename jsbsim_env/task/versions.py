"""The registered versions of the attitude task, as Gymnasium versions its environments: a change
to what a policy is trained on or flies with is a new version, and a run or policy file records the
version it was made with.

| version | training episodes | flight stack |
|---|---|---|
| ``SolarUAVAttitude-v0`` | the paper's task: Eq. 22's reward, control delays 80-120 ms | the network alone |
| ``SolarUAVAttitude-v1`` | surface trim at 0.5 x the PID's integral gains; reward with the roll and pitch penalties x2 and sideslip x6 (one cap for all three) and a tenth of each slope kept beyond its cap; delays 40-120 ms; 30 % of episodes with the throttle on a speed hold | goal trim (20 s) and surface trim at 2 x the PID's integral gains |
| ``SolarUAVAttitude-v2`` | v1's, with its flight stack around the network in every episode: goal trim (20 s) and surface trim at 2 x | the same: trained as flown |
| ``SolarUAVAttitude-v3`` | v1's without its surface trim; the network reads its roll, pitch and sideslip error integrals (``jsbsim_env.control.integrals``) | the error integrals and nothing else: trained as flown, integral action learned |
| ``SolarUAVAttitude-v4`` | v1's without its surface trim; the aircraft's designed LQI flies and the network adds a correction of up to a quarter of each surface's travel, reading the LQI's command and integrators (``jsbsim_env.control.residual``) | the same residual on the same LQI: trained as flown |
| ``SolarUAVAttitude-v5`` | v4's on the aircraft's tuned LQI (``lqi_tuned``; ``scripts/tune_classical.py`` writes it for a built aircraft) | the same: trained as flown |
| ``SolarUAVAttitude-v6`` | v4's on the aircraft's LQI tuned on flights drawn from v1's training episodes (``lqi_robust``; ``tune_classical.py --flights robust``) | the same: trained as flown |
| ``SolarUAVAttitude-v7`` | v5's with each goal held 10-30 s (v1: 3-10 s), so that most of an episode is spent holding a goal in turbulence, which the benchmark scores, rather than in step responses | v5's: trained as flown |
| ``SolarUAVAttitude-v8`` | v5's with the benchmark's stressed axes in the training draw: delays 40-200 ms, and each episode's servo rate limit the aircraft's own times 0.1-1 (uniform in its logarithm) | v5's: trained as flown |
| ``SolarUAVAttitude-v9`` | v7's on the aircraft's LQI tuned with the benchmark's stressed delay and servo rate among its flights (``lqi_stressed``; ``tune_classical.py --controller lqi --flights stressed``), so that the base keeps the margin a slow loop asks for | the same: trained as flown |
| ``SolarUAVAttitude-v10`` | v7's with the correction's authority a twentieth of each surface's travel (v5-v9: a quarter), the size of what a goal held in turbulence asks for, so that exploration stays that close to the tuned LQI | the same: trained as flown |

All train in the paper's disturbances otherwise (noise, random interval, coefficient spread,
0.5 m/s turbulence; v8 also slows the servos) and are evaluated in the paper's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from jsbsim_env.control.stack import FLIGHT_STACKS, RESIDUAL_AUTHORITY, StackSettings
from jsbsim_env.sim.core import CoreConfig
from jsbsim_env.task.attitude import TaskConfig

# The settings of the stages around the network, which the task and the flight stack both hold.
_STAGES = ("surface_trim_gain", "goal_trim_time_constant_s", "error_integrals", "residual_on", "residual_authority")


@dataclass(frozen=True)
class TaskVersion:
    """One registered version: the training episodes' task and the stack its policies fly with."""

    env_id: str
    task: TaskConfig
    flight_stack: StackSettings

    @property
    def trained_as_flown(self) -> bool:
        """Whether the training episodes run every stage of the flight stack with its settings."""
        return all(getattr(self.task, name) == getattr(self.flight_stack, name) for name in _STAGES)


def trained_as_flown(env_id: str, task: TaskConfig, stack: StackSettings) -> TaskVersion:
    """A version whose training episodes run ``stack``'s stages with its settings around the network."""
    return TaskVersion(env_id, replace(task, **{name: getattr(stack, name) for name in _STAGES}), stack)


# Each version's flight stack is ``control.stack.FLIGHT_STACKS``'s, which policy files are checked against.
V0 = TaskVersion("SolarUAVAttitude-v0", TaskConfig(), FLIGHT_STACKS["SolarUAVAttitude-v0"])
V1 = TaskVersion(
    "SolarUAVAttitude-v1",
    TaskConfig(core=CoreConfig(delay_s=(0.040, 0.120)),
               surface_trim_gain=0.5, sideslip_weight=6.0, roll_weight=2.0, pitch_weight=2.0, penalty_tail=0.1,
               external_throttle=0.3),
    FLIGHT_STACKS["SolarUAVAttitude-v1"],
)
V2, V3, V4, V5, V6 = (trained_as_flown(f"SolarUAVAttitude-v{n}", V1.task, FLIGHT_STACKS[f"SolarUAVAttitude-v{n}"])
                      for n in (2, 3, 4, 5, 6))
V7 = trained_as_flown("SolarUAVAttitude-v7", replace(V1.task, goal_hold_s=(10.0, 30.0)),
                      FLIGHT_STACKS["SolarUAVAttitude-v7"])
V8 = trained_as_flown("SolarUAVAttitude-v8",
                      replace(V1.task, core=replace(V1.task.core, delay_s=(0.040, 0.200), servo_rate_scale=(0.1, 1.0))),
                      FLIGHT_STACKS["SolarUAVAttitude-v8"])
V9 = trained_as_flown("SolarUAVAttitude-v9", V7.task, FLIGHT_STACKS["SolarUAVAttitude-v9"])
V10 = trained_as_flown("SolarUAVAttitude-v10", V7.task, FLIGHT_STACKS["SolarUAVAttitude-v10"])
VERSIONS = {v.env_id: v for v in (V0, V1, V2, V3, V4, V5, V6, V7, V8, V9, V10)}
LATEST = V1.env_id


def task_version(env_id: str) -> TaskVersion:
    """The version registered as ``env_id``; a clear error naming it and the known ones otherwise."""
    try:
        return VERSIONS[env_id]
    except KeyError:
        raise ValueError(f"task version {env_id!r} does not exist in this version of the package "
                         f"(it has {', '.join(VERSIONS)})") from None


__all__ = ["LATEST", "RESIDUAL_AUTHORITY", "VERSIONS", "TaskVersion", "task_version", "trained_as_flown"]
