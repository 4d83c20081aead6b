"""The attitude controllers the commands fly, by name: the trained policy (optionally with integral
trim) or the gain-scheduled PID. The loop bench, the sweeps, the ablation and the report build
theirs here."""

from __future__ import annotations

from jsbsim_env.controllers.integral_trim import IntegralTrim
from jsbsim_env.controllers.pid import PIDAttitudeController

CONTROLLER_NAMES = ("policy", "pid")


def make_controller(name: str, policy=None, integral_trim: float = 0.0, backend: str = "onnx"):
    """``"policy"``: ``policy`` (a policy file; the shipped one when None) run by ``backend``
    ("onnx" or "torch"), with ``IntegralTrim`` at ``integral_trim`` where > 0; ``"pid"``: the
    gain-scheduled PID."""
    if name == "policy":
        from training.policy import PolicyRuntime

        runtime = PolicyRuntime(policy, backend=backend)
        return IntegralTrim(runtime, integral_trim) if integral_trim else runtime
    if name == "pid":
        return PIDAttitudeController()
    raise ValueError(f"controller must be one of {', '.join(CONTROLLER_NAMES)}, got {name!r}")


__all__ = ["CONTROLLER_NAMES", "make_controller"]
