"""simulate(): accuracy of each method, energy, the singular lean, and argument checking."""

import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env import codegen, engine
from rolling_disk_env._generated import kernels
from rolling_disk_env.dynamics import LEAN_INDICES
from rolling_disk_env.integrators import ENGINE_METHODS, EVALUATIONS_PER_STEP

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
def test_convergence_order_of_simulate(method, order):
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
        if method == "dop853":  # one error control for the batch
            np.testing.assert_allclose(together[:, i], alone, rtol=1e-7, atol=1e-9)
        else:  # each disk its own steps: the same arithmetic
            np.testing.assert_array_equal(together[:, i], alone)


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


def _tableau_step(tableau, derivative, x, dt):
    """One step of a (partitioned) explicit Runge-Kutta tableau over the model API's derivative, in numpy: an
    independent reading of the tableau that the generated, written-out steps must agree with."""
    velocity = np.zeros(len(x), dtype=bool)
    velocity[-3:] = True
    slopes = []
    for stage in range(len(tableau.b)):
        offset = np.zeros(len(x))
        for j, k in enumerate(slopes):
            a_q = tableau.a[stage][j] if j < len(tableau.a[stage]) else 0
            a_v = tableau.rows(True)[0][stage][j] if j < len(tableau.rows(True)[0][stage]) else 0
            offset += np.where(velocity, float(a_v), float(a_q)) * k
        slopes.append(derivative(x + dt * offset))
    b_q, b_v = np.array(tableau.b, dtype=float), np.array(tableau.rows(True)[1], dtype=float)
    return x + dt * sum(np.where(velocity, bv, bq) * k for bq, bv, k in zip(b_q, b_v, slopes))


@pytest.mark.parametrize("tableau", codegen.TABLEAUS, ids=lambda tableau: tableau.name)
@pytest.mark.parametrize("model", ["state", "lean"])
def test_generated_steps_follow_their_tableaus(model, tableau):
    rng = np.random.default_rng(0)
    step = getattr(kernels, f"{model}_{tableau.name}_step")
    for _ in range(50):
        x = rng.uniform(-3, 3, 8)
        x[3] = rng.uniform(-1.2, 1.2)
        if model == "lean":
            x = x[list(LEAN_INDICES)]
        u = rng.uniform(-10, 10, 2)
        params = rd.DiskParams(*rng.uniform(0.5, 10, 3))
        dt = rng.uniform(1e-3, 0.05)
        derivative = rd.state_derivative if model == "state" else rd.lean_derivative
        expected = _tableau_step(tableau, lambda y, f=derivative, u=u, p=params: f(y, u, p), x, dt)
        arguments = (tuple(x), dt, *u, *params.constants) + ((1e-8, 1e-8) if tableau.error else ())
        result = step(*arguments)
        np.testing.assert_allclose(result[0] if tableau.error else result, expected, rtol=1e-12, atol=1e-12)


def test_dopri5_error_estimate_is_its_step_against_the_order_4_companion():
    # The error norm of one step, times the tolerance scale, is |x5 - x4|: compare with a step of the order-4 weights.
    x, dt, u = SCENARIO_1 + 0.3, 0.05, (1.0, -2.0)
    dopri5 = codegen.TABLEAUS[ENGINE_METHODS.index("dopri5")]
    order4 = codegen.Tableau("order4", "", dopri5.a, tuple(b - e for b, e in zip(dopri5.b, dopri5.error)))
    fifth = _tableau_step(dopri5, lambda y: rd.state_derivative(y, u), x, dt)
    fourth = _tableau_step(order4, lambda y: rd.state_derivative(y, u), x, dt)
    atol = 1e-6
    _, error = kernels.state_dopri5_step(tuple(x), dt, *u, *rd.DiskParams().constants, 0.0, atol)
    assert error == pytest.approx(np.sqrt(np.mean(((fifth - fourth) / atol) ** 2)), rel=1e-6)


@pytest.mark.parametrize(("method", "order"), [("rk4", 4), ("dopri5", 5)])
def test_fixed_steps_of_the_runge_kutta_methods_converge_at_their_order(method, order):
    _, reference = rd.simulate(SCENARIO_1, 1.0, 1.0, method="dop853", rtol=1e-13, atol=1e-13)
    step = getattr(kernels, f"state_{method}_step")
    extra = (1e-8, 1e-8) if method == "dopri5" else ()
    errors = []
    for steps in (40, 80):
        x = tuple(SCENARIO_1)
        for _ in range(steps):
            x = step(x, 1.0 / steps, 0.0, 0.0, *rd.DiskParams().constants, *extra)
            x = x[0] if method == "dopri5" else x
        errors.append(np.max(np.abs(np.array(x) - reference[-1])))
    assert np.log2(errors[0] / errors[1]) == pytest.approx(order, abs=0.3)


def test_the_engine_offers_every_tableau_and_the_benchmarks_cost_every_fixed_step():
    assert tuple(tableau.name for tableau in codegen.TABLEAUS) == ENGINE_METHODS == engine.METHODS
    assert set(EVALUATIONS_PER_STEP) == set(ENGINE_METHODS) - {"dopri5"}
    assert set(rd.METHODS) == {*ENGINE_METHODS, "dop853"}


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
        ({"rtol": 0.0}, "rtol"),
        ({"friction_coefficient": -1.0}, "friction_coefficient"),
    ],
)
def test_bad_arguments_raise_value_errors(kwargs, message):
    arguments = {"state0": SCENARIO_1, "duration": 1.0, "dt": 0.01, **kwargs}
    with pytest.raises(ValueError, match=message):
        rd.simulate(**arguments)
