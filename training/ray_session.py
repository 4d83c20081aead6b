"""Ray for the package's many-task jobs (sweeps, several seeds), an optional dependency."""

from __future__ import annotations

import contextlib


@contextlib.contextmanager
def ray_session(address: str | None = None):
    """Yields the ``ray`` module, initialised: on a local Ray instance started here and shut down
    on leaving, unless Ray is already running in this process or ``address`` names a cluster
    (``"auto"``: the one this machine belongs to). Tasks run with one OpenMP thread each.

    Raises:
        RuntimeError: Ray is not installed (it is the ``ray`` extra).
    """
    try:
        import ray
    except ImportError:
        raise RuntimeError("the ray backend needs Ray: pip install '.[ray]' (or use --backend local)") from None
    started = not ray.is_initialized()
    if started:
        ray.init(address=address, include_dashboard=False, log_to_driver=False,
                 runtime_env={"env_vars": {"OMP_NUM_THREADS": "1"}})
    try:
        yield ray
    finally:
        if started:
            ray.shutdown()


__all__ = ["ray_session"]
