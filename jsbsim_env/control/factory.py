"""The attitude controllers the commands fly, by name: a trained policy (with the control stack its
file records), the gain-scheduled PID or the gain-scheduled LQI, and the PID and the LQI re-tuned
on nonlinear flights (``scripts/tune_classical.py``, ``training.evaluation.classical_tuning``):
the same controllers with their tuned gain files (``TUNED_GAIN_FILES``). The loop bench, the
sweeps, the benchmark, the ablation and the report build theirs here."""

from __future__ import annotations

from pathlib import Path

from jsbsim_env.control.pid import PIDAttitudeController

TUNED_CONTROLLER_NAMES = ("pid_tuned", "lqi_tuned")
CONTROLLER_NAMES = ("policy", "pid", "lqi", *TUNED_CONTROLLER_NAMES)
_HERE = Path(__file__).parent
TUNED_GAIN_FILES = {"pid_tuned": _HERE / "pid_tuned_gains.json", "lqi_tuned": _HERE / "lqi_tuned_gains.json"}


class TunedGainsMissing(FileNotFoundError):
    """A tuned controller asked for before its gain file has been written."""


def tuned_gain_file(name: str) -> Path:
    """The gain file of the tuned controller ``name``; ``TunedGainsMissing`` (one line saying how to
    write it) where it has been deleted."""
    path = TUNED_GAIN_FILES[name]
    if not path.is_file():
        controller = name.removesuffix("_tuned")
        raise TunedGainsMissing(f"{name}: no tuned gain file {path}: write it with "
                                f"`python scripts/tune_classical.py --controller {controller}`")
    return path


def make_controller(name: str, policy=None, backend: str = "onnx", network_alone: bool = False):
    """``"policy"``: ``policy`` (a policy file; the shipped one when None) run by ``backend``
    ("onnx" or "torch"), without its classical stages where ``network_alone``
    (``PolicyRuntime``); ``"pid"``: the gain-scheduled PID; ``"lqi"``: the gain-scheduled LQI;
    ``"pid_tuned"``, ``"lqi_tuned"``: the same with their tuned gain files."""
    if name == "policy":
        from jsbsim_env.control.policy import PolicyRuntime

        return PolicyRuntime(policy, backend=backend, network_alone=network_alone)
    if network_alone:
        raise ValueError(f"network_alone is a setting of a policy, not of {name!r}")
    if name == "pid":
        return PIDAttitudeController()
    if name == "lqi":
        from jsbsim_env.control.lqi import LQIAttitudeController

        return LQIAttitudeController()
    if name == "pid_tuned":
        return PIDAttitudeController(gains_path=tuned_gain_file(name))
    if name == "lqi_tuned":
        from jsbsim_env.control.lqi import LQIAttitudeController

        return LQIAttitudeController(gains_path=tuned_gain_file(name))
    raise ValueError(f"controller must be one of {', '.join(CONTROLLER_NAMES)}, got {name!r}")


__all__ = ["CONTROLLER_NAMES", "TUNED_CONTROLLER_NAMES", "TUNED_GAIN_FILES", "TunedGainsMissing", "make_controller",
           "tuned_gain_file"]
