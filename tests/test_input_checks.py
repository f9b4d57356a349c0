"""Input checks without gaps: numpy scalars pass where Python numbers do, bools do not, malformed ranges and unknown
names are explained, initial states are checked at construction, and the model API names the DiskParams it wants."""

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd


@pytest.mark.parametrize(
    "kwargs",
    [
        {"dt": np.float32(0.02)},
        {"dt": np.float64(0.01)},
        {"dt": np.int64(1)},
        {"substeps": np.int64(2)},
        {"substeps": np.int32(3)},
        {"max_spin_torque": np.float32(4.0)},
        {"max_steer_torque": np.int64(8)},
        {"params_ranges": {"mass": (np.float32(4), np.int64(6))}},
        {"initial_ranges": {"dphi": (np.float32(0.9), np.float64(1.1))}},
        {"task_options": {"target_speed": np.float32(1.5), "fall_lean": np.float64(0.4)}},
        {"task_options": {"reward_weights": {"effort": np.float32(0.2)}}},
        {"task": "circle", "task_options": {"radius_range": np.array([3.0, 4.0]), "centre": (np.int64(1), 2)}},
    ],
)
def test_numpy_scalars_are_accepted_where_python_numbers_are(kwargs):
    env = gym.make(rd.ENV_ID, **kwargs)
    observation, _ = env.reset(seed=0)
    observation, *_ = env.step(env.action_space.sample())
    assert np.all(np.isfinite(observation))


def test_numpy_scalars_become_python_floats():
    params = rd.DiskParams(mass=np.float32(5), radius=np.int64(1))
    assert type(params.mass) is float and type(params.radius) is float
    assert params == rd.DiskParams(mass=5.0, radius=1.0)
    gym.make(rd.ENV_ID, params=rd.DiskParams(mass=np.float32(5), radius=np.float64(0.8), gravity=np.int64(10)))
    env = gym.make(rd.ENV_ID, dt=np.float32(0.02), substeps=np.int64(2)).unwrapped
    assert type(env.config.dt) is float and type(env.config.substeps) is int


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"substeps": True}, "substeps"),
        ({"substeps": np.bool_(True)}, "substeps"),
        ({"substeps": 2.0}, "substeps"),
        ({"dt": True}, "dt"),
        ({"max_spin_torque": True}, "max_spin_torque"),
        ({"task_options": {"target_speed": True}}, "target_speed"),
        ({"task_options": {"fall_lean": True}}, "fall_lean"),
        ({"task_options": {"reward_weights": {"alive": True}}}, "reward weight"),
    ],
)
def test_bools_are_not_numbers(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(rd.ENV_ID, **kwargs)


@pytest.mark.parametrize("field", ["mass", "radius", "gravity"])
def test_disk_params_refuse_bools(field):
    with pytest.raises(ValueError, match=field):
        rd.DiskParams(**{field: True})


@pytest.mark.parametrize(
    ("task", "bounds", "message"),
    [
        ("upright", (0.6, 0.7), "fall"),  # beyond upright's fall_lean of 0.5 rad: reset would return a fallen disk
        ("upright", (-0.51, 0.0), "fall"),
        ("circle", (0.7, 0.9), "fall"),  # circle's fall_lean is 0.8 rad
        ("upright", (1.6, 1.7), "domain"),  # beyond the model's domain, LEAN_LIMIT = pi/2 - 0.01
        ("circle", (-1.6, 0.0), "domain"),
    ],
)
def test_initial_leans_are_checked_at_construction(task, bounds, message):
    with pytest.raises(ValueError, match=message):
        gym.make(rd.ENV_ID, task=task, initial_ranges={"theta": bounds})
    with pytest.raises(ValueError, match=message):
        rd.RollingDiskVectorEnv(num_envs=2, task=task, initial_ranges={"theta": bounds})


def test_initial_leans_follow_the_tasks_fall_threshold():
    # The check is no stricter than reset's: up to the fall threshold is fine, and a raised threshold admits more.
    gym.make(rd.ENV_ID, initial_ranges={"theta": (-0.5, 0.5)})
    env = gym.make(rd.ENV_ID, initial_ranges={"theta": (0.6, 0.7)}, task_options={"fall_lean": 1.0})
    _, info = env.reset(seed=0)
    assert 0.6 <= info["state"][3] <= 0.7


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"params_ranges": {"mass": 5}}, r"params_ranges\['mass'\] must be a \(low, high\) pair"),
        ({"params_ranges": {"mass": (1, 2, 3)}}, r"\(low, high\) pair"),
        ({"params_ranges": {"mass": ("a", "b")}}, r"\(low, high\) pair"),
        ({"params_ranges": [("mass", (1, 2))]}, "params_ranges must be a dict"),
        ({"initial_ranges": {"theta": 0.1}}, r"initial-state range 'theta' must be a \(low, high\) pair"),
        ({"initial_ranges": {"dphi": "fast"}}, r"\(low, high\) pair"),
        ({"initial_ranges": (("theta", (0, 0.1)),)}, "initial_ranges must be a dict"),
        ({"task": "circle", "task_options": {"radius_range": 4.0}}, r"radius_range must be a \(low, high\) pair"),
        ({"task": "circle", "task_options": {"centre": 0.0}}, r"centre must be a \(x, y\) pair"),
    ],
)
def test_malformed_ranges_are_explained(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(rd.ENV_ID, **kwargs)


def test_unknown_keyword_arguments_list_the_valid_names():
    # Python's own wording, which TorchRL's GymEnv probes for before it retries without an optional argument.
    with pytest.raises(TypeError, match=r"got an unexpected keyword argument 'foo'") as error:
        gym.make(rd.ENV_ID, foo=1)
    for name in ("task", "dt", "substeps", "params", "initial_ranges", "task_options", "render_mode"):
        assert repr(name) in str(error.value)
    with pytest.raises(TypeError, match=r"'foo'.*'dt'"):
        rd.RollingDiskVectorEnv(num_envs=2, foo=1)


@pytest.mark.parametrize(
    ("task", "valid"),
    [
        ("upright", ["fall_lean", "reward_weights", "target_speed"]),
        ("circle", ["centre", "fall_lean", "radius_range", "reward_weights", "target_speed"]),
    ],
)
def test_unknown_task_options_list_the_valid_names(task, valid):
    with pytest.raises(ValueError, match=r"unknown task option.*'speed'") as error:
        gym.make(rd.ENV_ID, task=task, task_options={"speed": 2})
    assert str(valid) in str(error.value)
    with pytest.raises(ValueError, match="task_options must be a dict"):
        gym.make(rd.ENV_ID, task=task, task_options=[("target_speed", 2)])


@pytest.mark.parametrize(
    "call",
    [
        lambda params: rd.energy(np.zeros(8), params=params),
        lambda params: rd.contact_force(np.zeros(8), params=params),
        lambda params: rd.state_derivative(np.zeros(8), params=params),
        lambda params: rd.lean_derivative(np.zeros(4), params=params),
    ],
)
def test_the_model_api_names_the_params_it_expects(call):
    with pytest.raises(TypeError, match=r"params must be a DiskParams.*got dict"):
        call({"mass": 1})
    assert np.all(np.isfinite(call(rd.DiskParams(mass=np.float32(1)))))
