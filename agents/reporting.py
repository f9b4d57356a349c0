"""How sure a learning result is: the statistics of the learning benchmark, after Agarwal et al., *Deep
Reinforcement Learning at the Edge of the Statistical Precipice* (NeurIPS 2021) and their library rliable.

A score is one training run's (one seed's) final evaluation: its success rate, or its mean return normalized per task
(:func:`normalized`). Per cell (a task and a trainer) the point estimate is the interquartile mean (IQM) over the
runs, the mean of the middle half (``scipy.stats.trim_mean`` with a quarter cut at each end, rliable's
``aggregate_iqm``), robust to an outlying seed and less noisy than the median; its 95% interval is a percentile
bootstrap over the runs (:func:`percentile_interval`). Over the tasks, the IQM of every run's score pooled, its interval
a stratified bootstrap that resamples the runs within each task (:func:`stratified_interval`), as rliable's
``StratifiedBootstrap``. A performance profile gives, for each threshold tau, the fraction of runs scoring above it
(:func:`performance_profile`). The bootstraps use numpy's generator from a fixed seed, so a report is reproducible.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

CONFIDENCE = 0.95
"""The intervals' coverage."""
RESAMPLES = 10_000
"""Bootstrap resamples of an interval."""


def iqm(scores: np.ndarray, axis=None) -> np.ndarray | float:
    """The interquartile mean: the mean of the scores between the 25th and the 75th percentile (a quarter of them cut
    at each end, ``scipy.stats.trim_mean``); over ``axis`` (None: all)."""
    return stats.trim_mean(scores, 0.25, axis=axis)


def percentile_interval(scores: np.ndarray, seed: int = 0) -> tuple[float, float]:
    """The 95% percentile-bootstrap interval of the IQM of a cell's runs (``scores``, one a run): the 2.5th and
    97.5th percentiles of the IQM over :data:`RESAMPLES` resamples of the runs with replacement. Equal scores give an
    interval of zero width, one run an interval of its score."""
    scores = np.asarray(scores, dtype=float)
    if np.ptp(scores) == 0:
        return float(scores[0]), float(scores[0])
    result = stats.bootstrap(
        (scores,),
        lambda sample, axis: iqm(sample, axis=axis),
        n_resamples=RESAMPLES,
        confidence_level=CONFIDENCE,
        method="percentile",
        vectorized=True,
        rng=np.random.default_rng(seed),
    )
    return float(result.confidence_interval.low), float(result.confidence_interval.high)


def stratified_interval(scores_by_task: list[np.ndarray], seed: int = 0) -> tuple[float, float]:
    """The 95% interval of the IQM of all runs pooled over the tasks, by a stratified bootstrap: each resample draws,
    within each task, as many runs as it has, with replacement (rliable's ``StratifiedBootstrap``), then takes the IQM
    of the pooled draws; the interval is the 2.5th and 97.5th percentiles over :data:`RESAMPLES` resamples."""
    rng = np.random.default_rng(seed)
    draws = [
        np.asarray(task_scores, dtype=float)[rng.integers(0, len(task_scores), (RESAMPLES, len(task_scores)))]
        for task_scores in scores_by_task
    ]
    estimates = iqm(np.concatenate(draws, axis=1), axis=1)
    low, high = np.percentile(estimates, [100 * (1 - CONFIDENCE) / 2, 100 * (1 + CONFIDENCE) / 2])
    return float(low), float(high)


def normalized(returns: np.ndarray, low: float, high: float) -> np.ndarray:
    """Returns on the scale where ``low`` is 0 and ``high`` is 1 (for a task: the passive disk's mean return and the
    reference's, :func:`normalization`)."""
    return (np.asarray(returns, dtype=float) - low) / (high - low)


def normalization(passive: float, baseline: float, best: float) -> tuple[float, float, str]:
    """The task's scale of returns: from the passive disk's mean return (0) to the classical baseline's (1) where the
    baseline beats the passive disk by at least a tenth of the range the agents span (from the passive disk to the best
    of the baseline and the agents, ``best`` being the agents' best mean return); else to the best agent's. Returns
    ``(low, high, reference)``, the reference ``"baseline"`` or ``"best agent"`` (where nothing beats the passive
    disk, ``"none beats the passive disk"`` and a unit range above it)."""
    span = max(baseline, best) - passive
    if span <= 0:  # nothing does better than the passive disk: a scale of its own return's units
        return passive, passive + 1.0, "none beats the passive disk"
    if baseline - passive >= 0.1 * span:
        return passive, baseline, "baseline"
    return passive, best, "best agent"


def performance_profile(scores: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """The fraction of ``scores`` (runs) above each threshold tau (rliable's run-score distribution)."""
    scores = np.asarray(scores, dtype=float)
    return (scores[None, :] > np.asarray(thresholds, dtype=float)[:, None]).mean(axis=1)
