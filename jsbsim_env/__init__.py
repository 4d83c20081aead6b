"""Simulation, control and reinforcement-learning environments for the solar UAV in JSBSim.

Subpackages, bottom to top (each imports only from those below it; ``lint-imports`` checks it):
``sim`` (JSBSim and the flight core), ``analysis`` (modes, derivatives, effectiveness,
runscripts), ``control`` (PID, TECS, L1 and the learned controller's stack and runtime), ``task``
(the attitude task, its versions and its two environments), ``missions`` (routes) and ``bench``
(the loop bench).

Importing the package registers the gymnasium environments ``SolarUAVAttitude-v0`` (the paper's
task) and ``SolarUAVAttitude-v1`` (the shipped controller's); the TorchRL environment is
``jsbsim_env.task.torchrl_env.SolarUAVAttitudeEnv`` (``make_env`` for training).
"""

from .sim import ModelError, Simulation, TrimError, TrimResult
from .task.gym_env import ENV_ID, register

register()

__all__ = ["ENV_ID", "ModelError", "Simulation", "TrimError", "TrimResult"]
