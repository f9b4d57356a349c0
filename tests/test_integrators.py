"""simulate(): accuracy of each method, energy, the singular lean, and argument checking."""

import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.dynamics import FULL_MODEL, LEAN_INDICES, LEAN_MODEL
from rolling_disk_env.integrators import EVALUATIONS_PER_STEP, STEPS, rk4

SCENARIO_1 = np.array([2, 0, 0, 0.1, 0, 2.5, 0, 0])


def _relative_drift(states) -> float:
    energies = rd.energy(states)
    return float(np.max(np.abs(energies - energies[0])) / energies[0])


def test_dop853_conserves_energy_to_1e_9_over_10_s():
    _, states = rd.simulate(SCENARIO_1, 10.0, 0.01, method="dop853")
    assert _relative_drift(states) < 1e-9


def test_rk4_energy_drift_at_dt_0_01(record_property):
    _, states = rd.simulate(SCENARIO_1, 10.0, 0.01, method="rk4")
    drift = _relative_drift(states)
    record_property("rk4_relative_energy_drift_dt_0.01", drift)
    print(f"RK4, dt = 0.01 s, scenario 1, 10 s: relative energy drift {drift:.3g}")
    assert drift < 1e-8


@pytest.mark.parametrize(("method", "order"), [("euler", 1), ("symplectic_euler", 1), ("rk4", 4)])
def test_convergence_order(method, order):
    _, reference = rd.simulate(SCENARIO_1, 2.0, 0.1, method="dop853", rtol=1e-13, atol=1e-13)
    errors = []
    for dt in (0.01, 0.005):
        _, states = rd.simulate(SCENARIO_1, 2.0, dt, method=method)
        errors.append(np.max(np.abs(states[-1] - reference[-1])))
    assert np.log2(errors[0] / errors[1]) == pytest.approx(order, abs=0.15)


@pytest.mark.parametrize("method", rd.METHODS)
def test_batched_simulation_equals_one_by_one(method):
    states0 = np.array([SCENARIO_1, [0, 1, 2, -0.3, 1, -3.0, 0.5, 0.2]])
    torque = np.array([[0.5, 0.0], [-1.0, 2.0]])
    _, together = rd.simulate(states0, 1.0, 0.01, method=method, torque=torque)
    for i, x0 in enumerate(states0):
        _, alone = rd.simulate(x0, 1.0, 0.01, method=method, torque=torque[i])
        np.testing.assert_allclose(together[:, i], alone, rtol=1e-7 if method == "dop853" else 1e-13, atol=1e-9)


def test_torque_callable_is_sampled_per_step():
    calls = []

    def spin_up(t, state):
        calls.append(t)
        return [2.0, 0.0]

    times, with_callable = rd.simulate(SCENARIO_1, 1.0, 0.1, torque=spin_up)
    _, with_constant = rd.simulate(SCENARIO_1, 1.0, 0.1, torque=[2.0, 0.0])
    np.testing.assert_array_equal(with_callable, with_constant)
    np.testing.assert_allclose(calls, times[:-1])


def test_output_times_end_exactly_at_duration():
    times, states = rd.simulate(SCENARIO_1, 1.0, 0.3)
    np.testing.assert_allclose(times, [0, 0.3, 0.6, 0.9, 1.0])
    assert states.shape == (5, 8)


@pytest.mark.parametrize("model", [FULL_MODEL, LEAN_MODEL], ids=lambda model: model.name)
def test_written_out_rk4_step_is_rk4_to_the_last_bit(model):
    rng = np.random.default_rng(0)
    for _ in range(500):
        x = rng.uniform(-5, 5, 8)
        x[3] = rng.uniform(-1.5, 1.5)
        if model is LEAN_MODEL:
            x = x[list(LEAN_INDICES)]
        args = (*rng.uniform(-10, 10, 2), *rng.uniform(0.1, 20, 3))
        dt = rng.uniform(1e-4, 0.1)
        assert model.scalar_rk4(x.tolist(), dt, *args) == rk4(model.scalar, x.tolist(), dt, args)


def test_evaluations_table_covers_every_fixed_step_method():
    assert set(EVALUATIONS_PER_STEP) == set(STEPS)
    assert set(rd.METHODS) == {*STEPS, "dop853"}


FALLING = np.array([0, 0, 0, 1.2, 0, 0.0, 0.5, 0.0])


@pytest.mark.parametrize("method", rd.METHODS)
@pytest.mark.parametrize("batched", [False, True])
def test_falling_flat_stops_with_a_domain_error_naming_time_and_theta(method, batched):
    state0 = np.array([FALLING, SCENARIO_1]) if batched else FALLING
    # The disk falls flat in about 0.25 s; a fixed-step method reports the step that crossed the limit, dop853 the
    # crossing itself (an event).
    with pytest.raises(rd.OutOfDomainError, match=r"theta = .* rad at t = .* s") as error:
        rd.simulate(state0, 5.0, 0.01, method=method)
    assert 0.2 < error.value.time < 0.3
    assert abs(error.value.theta) >= rd.LEAN_LIMIT - 1e-9


def test_a_diverging_integrator_stops_with_an_error_not_nan():
    # Explicit Euler with a huge step from a fast-spinning disk.
    with pytest.raises(rd.OutOfDomainError):
        rd.simulate(np.array([0, 0, 0, 0.3, 0, 40.0, 5.0, 30.0]), 100.0, 0.5, method="euler")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"method": "rk45"}, "method"),
        ({"model": "half"}, "model"),
        ({"dt": -0.1}, "dt"),
        ({"dt": float("nan")}, "dt"),
        ({"duration": 0.0}, "duration"),
        ({"torque": [1.0, 2.0, 3.0]}, "torque"),
        ({"torque": lambda t, x: [np.nan, 0.0]}, "torque"),
        ({"state0": np.zeros(4)}, "state0"),
        ({"state0": [0, 0, 0, 1.6, 0, 0, 0, 0]}, "domain"),
    ],
)
def test_bad_arguments_raise_value_errors(kwargs, message):
    arguments = {"state0": SCENARIO_1, "duration": 1.0, "dt": 0.01, **kwargs}
    with pytest.raises(ValueError, match=message):
        rd.simulate(**arguments)
