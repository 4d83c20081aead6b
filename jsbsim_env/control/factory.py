"""The attitude controllers the commands fly, by name: a trained policy (with the control stack its
file records), the gain-scheduled PID or the gain-scheduled LQI. The loop bench, the sweeps, the ablation and the report
build theirs here."""

from __future__ import annotations

from jsbsim_env.control.pid import PIDAttitudeController

CONTROLLER_NAMES = ("policy", "pid", "lqi")


def make_controller(name: str, policy=None, backend: str = "onnx"):
    """``"policy"``: ``policy`` (a policy file; the shipped one when None) run by ``backend``
    ("onnx" or "torch"); ``"pid"``: the gain-scheduled PID; ``"lqi"``: the gain-scheduled LQI."""
    if name == "policy":
        from jsbsim_env.control.policy import PolicyRuntime

        return PolicyRuntime(policy, backend=backend)
    if name == "pid":
        return PIDAttitudeController()
    if name == "lqi":
        from jsbsim_env.control.lqi import LQIAttitudeController

        return LQIAttitudeController()
    raise ValueError(f"controller must be one of {', '.join(CONTROLLER_NAMES)}, got {name!r}")


__all__ = ["CONTROLLER_NAMES", "make_controller"]
