"""The learning benchmark's statistics (agents/reporting.py) against rliable's on a fixed-seed table, exact on
degenerate inputs, and the normalization of returns."""

import numpy as np
import pytest
from rliable import library as rly
from rliable import metrics

from agents import reporting

TABLE = np.random.default_rng(0).beta(2.0, 1.5, size=(10, 4))
"""Scores of 10 runs on 4 tasks (a fixed draw)."""


def test_the_iqm_is_rliables():
    assert reporting.iqm(TABLE) == pytest.approx(metrics.aggregate_iqm(TABLE), abs=1e-15)
    for task in range(4):
        assert reporting.iqm(TABLE[:, task]) == pytest.approx(metrics.aggregate_iqm(TABLE[:, task : task + 1]))


def test_the_intervals_agree_with_rliables_within_the_bootstraps_own_spread():
    # Different generators: the endpoints agree within the Monte Carlo error of 10,000 resamples (about 0.005 here).
    np.random.seed(1)  # noqa: NPY002 (rliable's bootstrap draws from numpy's global generator: this seeds it)
    point, intervals = rly.get_interval_estimates(
        {"agent": TABLE}, lambda scores: np.array([metrics.aggregate_iqm(scores)]), reps=10_000
    )
    low, high = reporting.stratified_interval([TABLE[:, task] for task in range(4)], seed=2)
    np.testing.assert_allclose([low, high], intervals["agent"][:, 0], atol=0.015)
    one_task = TABLE[:, :1]
    _, one = rly.get_interval_estimates(
        {"agent": one_task}, lambda scores: np.array([metrics.aggregate_iqm(scores)]), reps=10_000
    )
    np.testing.assert_allclose(reporting.percentile_interval(one_task[:, 0], seed=3), one["agent"][:, 0], atol=0.03)
    assert low < point["agent"][0] < high


def test_equal_scores_give_an_interval_of_zero_width():
    assert reporting.percentile_interval(np.full(5, 0.7)) == (0.7, 0.7)
    assert reporting.stratified_interval([np.full(5, 1.0), np.full(3, 1.0)]) == (1.0, 1.0)
    assert reporting.iqm(np.full(5, 0.7)) == pytest.approx(0.7)


def test_the_normalization_puts_the_passive_disk_at_0_and_the_baseline_at_1():
    low, high, reference = reporting.normalization(passive=-130.0, baseline=175.0, best=190.0)
    assert (low, high, reference) == (-130.0, 175.0, "baseline")
    np.testing.assert_array_equal(reporting.normalized([-130.0, 175.0], low, high), [0.0, 1.0])
    # A baseline barely above the passive disk: the best agent's return is the 1 instead.
    assert reporting.normalization(passive=-100.0, baseline=-95.0, best=300.0) == (-100.0, 300.0, "best agent")
    # nothing beats the passive disk (a sparse task's zero returns): a finite scale, 0 at the passive disk
    low, high, reference = reporting.normalization(passive=0.0, baseline=0.0, best=0.0)
    assert (low, high, reference) == (0.0, 1.0, "none beats the passive disk")
    assert reporting.normalized([0.0, 0.0], low, high).tolist() == [0.0, 0.0]


def test_a_performance_profile_is_the_fraction_of_runs_above_each_threshold():
    profile = reporting.performance_profile(np.array([0.1, 0.5, 0.5, 0.9]), np.array([0.0, 0.5, 0.95]))
    np.testing.assert_array_equal(profile, [1.0, 0.25, 0.0])
