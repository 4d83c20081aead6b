"""Make the suite independent of whatever else runs on the machine.

pytest keeps only the last three numbered temporary folders (``/tmp/pytest-of-USER/pytest-N``)
and deletes older ones when a session starts, so with several suites running at once one could
delete another's folders mid-run. Each session here gets its own temporary root instead, unless
``--basetemp`` is given.

BLAS runs on one thread: the trim's least-squares steps are tiny, and a multi-threaded BLAS on
an oversubscribed machine only adds a source of run-to-run difference.
"""

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import shutil  # after the thread settings, before anything imports numpy
import tempfile


def pytest_configure(config):
    if config.option.basetemp is None and not hasattr(config, "workerinput"):
        config.option.basetemp = tempfile.mkdtemp(prefix="solar-uav-tests-")
        config._solar_uav_basetemp = config.option.basetemp


def pytest_unconfigure(config):
    root = getattr(config, "_solar_uav_basetemp", None)
    if root:
        shutil.rmtree(root, ignore_errors=True)
