"""The attitude controllers the commands fly, by name: a trained policy (with the control stack its
file records), the gain-scheduled PID or the gain-scheduled LQI, and the PID and the LQI re-tuned
on nonlinear flights (``scripts/tune_classical.py``, ``training.evaluation.classical_tuning``):
the same controllers with their tuned gain files (``TUNED_GAIN_FILES``). The loop bench, the
sweeps, the benchmark, the ablation and the report build theirs here."""

from __future__ import annotations

from pathlib import Path

from aircraft import load_aircraft
from jsbsim_env.control.gain_files import FILES, PACKAGED_DIR, GainTableError, gain_file
from jsbsim_env.control.gain_files import GainsMissing as TunedGainsMissing
from jsbsim_env.control.pid import PIDAttitudeController

# Tuned on the held-out flights (nominal conditions), on the robust ones (the training episodes'
# distribution of conditions) and, the LQI, on the stressed ones (a long delay and a slow servo
# among them): ``training.evaluation.classical_tuning``.
TUNED_CONTROLLER_NAMES = ("pid_tuned", "lqi_tuned", "pid_robust", "lqi_robust", "lqi_stressed")
CONTROLLER_NAMES = ("policy", "pid", "lqi", *TUNED_CONTROLLER_NAMES)
TUNED_GAIN_FILES = {name: PACKAGED_DIR / FILES[name] for name in TUNED_CONTROLLER_NAMES}  # the paper's aircraft's


def tuned_gain_file(name: str, aircraft=None) -> Path:
    """The gain file of the tuned controller ``name`` of ``aircraft`` (the paper's by default);
    ``TunedGainsMissing`` (one line saying how to write it) where it has not been written."""
    return gain_file(name, aircraft)


def check_gain_table(name: str, path: Path) -> None:
    """The gain table at ``path`` read as the controller ``name`` reads it: its values checked
    (finite, the right controller, signs and trims); ``GainTableError`` in one line otherwise."""
    try:
        if name.startswith("pid"):
            from jsbsim_env.control.pid import GainSchedule

            GainSchedule(path)
        else:
            from jsbsim_env.control.lqi import LQIGainSchedule

            LQIGainSchedule(path)
    except ValueError as err:
        raise GainTableError(str(err)) from None


def check_flyable(names, aircraft=None, policies: dict | None = None, transfer: bool = False) -> dict:
    """Before any flight: each classical controller of ``names`` has ``aircraft``'s gain table
    (``TunedGainsMissing`` otherwise) and can fly it (``GainTableError`` otherwise), and each policy file of ``policies`` (label -> path) reads
    and was trained on ``aircraft`` unless ``transfer`` (``PolicyFileError``, ``WrongAircraftError``).
    Returns each policy's metadata (``load_policy``) by label."""
    from jsbsim_env.control.policy import check_aircraft, load_policy

    for name in names:
        if name != "policy":
            check_gain_table(name, gain_file(name, aircraft))
    flown = load_aircraft(aircraft)
    metas = {}
    for label, path in (policies or {}).items():
        metas[label] = meta = load_policy(path)[1]
        if not transfer:
            check_aircraft(meta, Path(path), flown)
    return metas


def make_controller(name: str, policy=None, backend: str = "onnx", network_alone: bool = False, aircraft=None,
                    transfer: bool = False):
    """The controller ``name`` for ``aircraft`` (``aircraft.load_aircraft``; the paper's by default).

    ``"policy"``: ``policy`` (a policy file; the shipped one when None) run by ``backend``
    ("onnx" or "torch"), without its classical stages where ``network_alone``
    (``PolicyRuntime``); refused on an aircraft other than the one it was trained on unless
    ``transfer``. ``"pid"``: the gain-scheduled PID; ``"lqi"``: the gain-scheduled LQI;
    ``"pid_tuned"``, ``"lqi_tuned"``: the same with their tuned gain files, ``"pid_robust"``,
    ``"lqi_robust"`` with those tuned on the robust flights, ``"lqi_stressed"`` on the stressed ones. The classical
    controllers fly the aircraft's own gain tables (``gain_files``)."""
    if name == "policy":
        from jsbsim_env.control.policy import PolicyRuntime

        return PolicyRuntime(policy, backend=backend, network_alone=network_alone, aircraft=aircraft,
                             transfer=transfer)
    if network_alone:
        raise ValueError(f"network_alone is a setting of a policy, not of {name!r}")
    if name == "pid":
        return PIDAttitudeController(aircraft=aircraft)
    if name == "lqi":
        from jsbsim_env.control.lqi import LQIAttitudeController

        return LQIAttitudeController(aircraft=aircraft)
    if name in ("pid_tuned", "pid_robust"):
        return PIDAttitudeController(gains_path=tuned_gain_file(name, aircraft), aircraft=aircraft)
    if name in ("lqi_tuned", "lqi_robust", "lqi_stressed"):
        from jsbsim_env.control.lqi import LQIAttitudeController

        return LQIAttitudeController(gains_path=tuned_gain_file(name, aircraft), aircraft=aircraft)
    raise ValueError(f"controller must be one of {', '.join(CONTROLLER_NAMES)}, got {name!r}")


__all__ = [
    "CONTROLLER_NAMES",
    "TUNED_CONTROLLER_NAMES",
    "TUNED_GAIN_FILES",
    "GainTableError",
    "TunedGainsMissing",
    "check_flyable",
    "check_gain_table",
    "make_controller",
    "tuned_gain_file",
]
