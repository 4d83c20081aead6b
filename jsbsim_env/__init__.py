"""Simulation core and reinforcement-learning environments for the solar UAV in JSBSim.

Importing the package registers the gymnasium environment ``SolarUAVAttitude-v0``; the TorchRL
environment is ``jsbsim_env.task.torchrl_env.SolarUAVAttitudeEnv`` (``make_env`` for training).
"""

from .task.gym_env import ENV_ID, register
from .sim import ModelError, Simulation, TrimError, TrimResult

register()

__all__ = ["ENV_ID", "ModelError", "Simulation", "TrimError", "TrimResult"]
