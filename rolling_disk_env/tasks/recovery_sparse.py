"""``task="recovery_sparse"``: ``recovery`` with its reward only where it succeeds, the ladder's exploration rung.

The same disk, starts, observation, success and episodes as ``recovery`` (:mod:`rolling_disk_env.tasks.recovery`,
whose kernels and generated steps this task runs), and the same reward terms reported in ``info``; but only
``recovered`` weighs: the reward is 1 on the step that ends the episode as a success, 0 on every other. As DeepMind
Control's ``_sparse`` tasks do for theirs, it asks what a learner finds without a shaped signal: from these starts
a random policy never holds upright rolling for a second, so the first success has to be found by exploration. That
the task can be solved from its observation, a policy trained on ``recovery``'s shaped reward shows (it succeeds on
the same starts by the same rule: ``benchmarks/results/learning.md``).
"""

from __future__ import annotations

from typing import ClassVar

from rolling_disk_env.tasks.recovery import RecoveryTask, advance, observe, reward_terms, start, termination

__all__ = ["RecoverySparseTask", "advance", "observe", "reward_terms", "start", "termination"]  # recovery's kernels


class RecoverySparseTask(RecoveryTask):
    """:class:`~rolling_disk_env.tasks.recovery.RecoveryTask` with the reward of success alone: default weights 0 but
    ``recovered`` 1 (``reward_weights`` sets others, as for every task)."""

    name = "recovery_sparse"
    steps_of = "recovery"
    default_reward_weights: ClassVar[dict[str, float]] = {
        name: 1.0 if name == "recovered" else 0.0 for name in RecoveryTask.default_reward_weights
    }
