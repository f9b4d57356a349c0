"""Training, evaluation and baselines on top of rolling-disk-env."""

import logging


def show_compiling() -> None:
    """Shows the package's INFO log lines, those that say when numba compiles an env's kernels and how long it took
    (``rolling_disk_env.envs.batch.logger``): the first run of a configuration waits tens of seconds for them."""
    logging.basicConfig(format="%(message)s")
    logging.getLogger("rolling_disk_env").setLevel(logging.INFO)
