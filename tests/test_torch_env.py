"""The torch interface of the vector env (``make_vec(..., device=...)``): the same transitions as the numpy vector env
in every autoreset mode, tensors of the documented dtypes, the CPU engine's outputs without a copy, and clear errors.
``tests/test_gpu.py`` runs :func:`paired_rollout` on the CUDA kernels."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from gymnasium.vector import AutoresetMode

import rolling_disk_env as rd

FINAL_KEYS = ("final_obs", "_final_obs", "final_info", "_final_info")
STEPS, LIMIT = 200, 40
"""Steps of a paired rollout, and episode steps before truncation (every sub-environment is reset several times)."""


def make(num_envs: int, mode=AutoresetMode.NEXT_STEP, device=None, **kwargs):
    """The ids' vector env, numpy (``device`` None) or torch, with the numpy env's info keys (``info_keys="full"``)
    unless told otherwise."""
    extra = {} if device is None else {"device": device, "info_keys": kwargs.pop("info_keys", "full")}
    return gym.make_vec(
        rd.ENV_ID,
        num_envs=num_envs,
        vectorization_mode="vector_entry_point",
        max_episode_steps=LIMIT,
        autoreset_mode=mode,
        **extra,
        **kwargs,
    )


def _numpy(value):
    return value.cpu().numpy() if isinstance(value, torch.Tensor) else np.asarray(value)


def _assert_close(ours, theirs, rtol: float, where: str, extra: np.ndarray | None = None) -> None:
    """Floats within ``rtol`` of the numpy env's, relative to each array's largest value, each row also allowed
    ``extra`` where given (on the norm of a row's error, for 2-D); other dtypes equal."""
    ours, theirs = _numpy(ours), _numpy(theirs)
    assert ours.shape == theirs.shape, where
    if theirs.dtype.kind != "f":
        np.testing.assert_array_equal(ours, theirs, err_msg=where)
        return
    scale = max(float(np.max(np.abs(theirs), initial=0.0)), 1.0)
    if extra is None:
        np.testing.assert_allclose(ours, theirs, rtol=0.0, atol=rtol * scale, err_msg=where)
        return
    same_nan = np.isnan(ours) & np.isnan(theirs)  # equal, as assert_allclose has them
    error = np.abs(ours - theirs) if theirs.ndim == 1 else np.linalg.norm(ours - theirs, axis=1)
    error = np.where(same_nan if theirs.ndim == 1 else same_nan.all(axis=1), 0.0, error)
    excess = error - rtol * scale - extra
    assert np.all(excess <= 0.0), f"{where}: disk {np.argmax(excess)} off by {np.max(excess):.3g} beyond tolerance"


def _slide_allowance(info: dict, rtol: float, rows) -> np.ndarray:
    """Per sub-environment, what the kinetic law ``-mu N v / |v|`` of a sliding disk makes of its slip velocity's
    rounding ``dv`` (``rtol`` times the largest slip velocity component, or times 1 m/s if that is larger): an error
    ``|F| dv / |v|`` in its friction force ``F`` (N), which grows as a slide stops (at most ``2 |F|``: the direction
    alone undetermined); zero where the disk rolls. A GPU's fused multiply-adds round ``v`` differently: 7e-10 N seen
    on 4.9 N."""
    force, velocity = np.asarray(info["contact_force"])[rows], np.asarray(info["slip_velocity"])[rows]
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    dv = rtol * max(float(np.max(np.abs(velocity), initial=0.0)), 1.0)
    angle = np.minimum(dv / np.maximum(speed, 1e-300), 2.0)
    return np.where(np.asarray(info["sliding"])[rows], np.hypot(force[:, 0], force[:, 1]) * angle, 0.0)


NORMAL_FORCE_GAIN = 4.0
"""The normal force of a sliding disk follows its friction through the dynamics: ``|dN / d(angle of F)|`` stays
below ``3.2 |F|`` over random sliding states (the test below)."""


def test_the_normal_force_follows_the_friction_by_less_than_the_gain():
    """The basis of :data:`NORMAL_FORCE_GAIN`: turning a sliding disk's friction (``mu N`` along an angle) changes
    the normal force ``N`` by less than the gain times ``|F|`` a radian, over random states (lean to 1.2 rad, rates
    to 5 rad/s, mu 0.05 to 1.1); and by more than a tenth of it somewhere, so the check sees the coupling."""
    from rolling_disk_env._generated import sliding

    rng, worst, m, g, r = np.random.default_rng(0), 0.0, 5.0, 9.81, 1.0
    for _ in range(3000):
        x = np.zeros(10)
        x[2], x[3], x[4] = rng.uniform(-3, 3), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3)
        x[5:8], x[8:] = rng.uniform(-5, 5, 3), rng.uniform(-3, 3, 2)
        u, mu, angle, h = rng.uniform(-1, 1, 2), rng.uniform(0.05, 1.1), rng.uniform(0, 2 * np.pi), 1e-6
        normal = [
            sliding.friction_diagnostics(tuple(x), *u, mu * np.cos(a), mu * np.sin(a), m, g, r)[1]
            for a in (angle, angle + h)
        ]
        if normal[0] > 0.0:
            worst = max(worst, abs(normal[1] - normal[0]) / h / (mu * normal[0]))
    assert NORMAL_FORCE_GAIN / 10 < worst < NORMAL_FORCE_GAIN


def _assert_infos_close(ours: dict, theirs: dict, rtol: float, where: str, rows=slice(None)) -> None:
    """Every key of the numpy env's info in ours, as tensors, close on the sub-environments ``rows``. On the GPU,
    SAME_STEP's final keys are there at every step: where the numpy env has none, their masks hold no True."""
    if "final_obs" in ours and "final_obs" not in theirs:
        assert not _numpy(ours["_final_obs"]).any() and not _numpy(ours["_final_info"]).any(), where
        ours = {key: value for key, value in ours.items() if key not in FINAL_KEYS}
    assert ours.keys() == theirs.keys(), where
    for key, value in theirs.items():
        if key == "final_info":  # meaningful where the episodes ended
            _assert_infos_close(ours[key], value, rtol, f"{where}[final_info]", np.asarray(theirs["_final_info"]))
        elif key == "final_obs":
            ended = np.asarray(theirs["_final_obs"])
            stacked = np.stack([value[i] for i in np.flatnonzero(ended)]) if ended.any() else np.zeros((0,))
            _assert_close(_numpy(ours[key])[ended].reshape(stacked.shape), stacked, rtol, f"{where}[final_obs]")
        else:
            assert isinstance(ours[key], torch.Tensor), f"{where}[{key}] is a {type(ours[key])}"
            if key in ("contact_force", "normal_force") and "sliding" in theirs:
                extra = _slide_allowance(theirs, rtol, rows) * (1.0 if key == "contact_force" else NORMAL_FORCE_GAIN)
                _assert_close(_numpy(ours[key])[rows], np.asarray(value)[rows], rtol, f"{where}[{key}]", extra)
            else:
                _assert_close(_numpy(ours[key])[rows], np.asarray(value)[rows], rtol, f"{where}[{key}]")


def paired_rollout(device: str, mode: AutoresetMode, rtol: float, num_envs: int = 64, **kwargs) -> None:
    """Steps the torch env on ``device`` and the numpy vector env from the same seed under the same random actions
    (``STEPS`` of them, with resets): observations, rewards and every info value within ``rtol`` (relative to the
    largest of each), flags and codes equal. Under DISABLED, the ended sub-environments are reset by mask."""
    ours, theirs = make(num_envs, mode, device, **kwargs), make(num_envs, mode, **kwargs)
    observations, info = ours.reset(seed=7)
    expected, expected_info = theirs.reset(seed=7)
    assert observations.dtype == torch.float32 and observations.shape == expected.shape
    _assert_close(observations, expected, rtol, "reset")
    _assert_infos_close(info, expected_info, rtol, "reset info")
    rng = np.random.default_rng(0)
    ended = 0
    for step in range(STEPS):
        actions = rng.uniform(-1.5, 1.5, theirs.action_space.shape).astype(np.float32)
        got = ours.step(torch.from_numpy(actions).to(observations.device))
        want = theirs.step(actions)
        where = f"step {step}"
        assert got[1].dtype == torch.float32 and got[2].dtype == torch.bool and got[3].dtype == torch.bool, where
        for name, index in (("observations", 0), ("rewards", 1), ("terminated", 2), ("truncated", 3)):
            _assert_close(got[index], want[index].astype(np.float32) if index == 1 else want[index], rtol, where + name)
        _assert_infos_close(got[4], want[4], rtol, where)
        done = want[2] | want[3]
        ended += int(done.sum())
        if mode == AutoresetMode.DISABLED and done.any():
            ours.reset(options={"reset_mask": torch.from_numpy(done)})
            theirs.reset(options={"reset_mask": done})
    assert ended >= num_envs, f"only {ended} episodes ended: the resets were not exercised"
    ours.close()
    theirs.close()


CASES = {
    "upright": {"task": "upright"},
    "circle-coulomb": {"task": "circle", "contact": "coulomb", "friction_coefficient": 0.2},
    "goto-sliding": {"task": "goto", "contact": "sliding", "friction_coefficient": 0.3},
}


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda mode: mode.value)
@pytest.mark.parametrize("kwargs", list(CASES.values()), ids=list(CASES))
def test_cpu_device_gives_the_numpy_env_transitions_to_the_last_bit(kwargs, mode):
    paired_rollout("cpu", mode, 0.0, num_envs=16, **kwargs)


def test_cpu_device_hands_out_the_engine_arrays_without_a_copy():
    envs = make(4, device="cpu")
    observations, _ = envs.reset(seed=0)
    observations, *_, info = envs.step(torch.zeros(envs.action_space.shape))
    last = envs.unwrapped._last  # the batch's outputs of that step
    assert observations.data_ptr() == last.observations.ctypes.data
    assert info["energy"].data_ptr() == last.info[rd.engine.ENERGY].ctypes.data
    assert info["state"].dtype == torch.float64 and info["state"].shape == (4, 8)
    assert info["termination"].dtype == torch.int64 and info["is_success"].dtype == torch.bool


@pytest.mark.parametrize(
    "actions",
    [
        np.zeros((4, 2)),
        [[0.5, -0.5]] * 4,
        torch.zeros((4, 2), dtype=torch.float64),
        torch.ones((4, 2), dtype=torch.int32),
    ],
    ids=["numpy-float64", "list", "float64", "int32"],
)
def test_actions_of_another_type_are_converted(actions):
    envs = make(4, device="cpu")
    envs.reset(seed=0)
    reference = make(4)
    reference.reset(seed=0)
    observations = envs.step(actions)[0]
    expected = reference.step(np.clip(np.asarray(actions, dtype=np.float64), -1, 1).astype(np.float32))[0]
    np.testing.assert_array_equal(observations.numpy(), expected)


@pytest.mark.parametrize(
    ("actions", "message"),
    [
        (torch.full((4, 2), float("nan")), "finite"),
        (torch.full((4, 2), float("inf"), dtype=torch.float64), "finite"),
        (torch.zeros((4, 3)), "shape"),
        (torch.zeros((4, 2), dtype=torch.bool), "finite numbers"),
        ("left", "tensor or array of numbers"),
    ],
    ids=["nan", "inf-float64", "shape", "bool", "string"],
)
def test_bad_actions_raise_a_clear_error(actions, message):
    envs = make(4, device="cpu")
    envs.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        envs.step(actions)


@pytest.mark.parametrize("device", ["tpu", "cuda:7", 3])
def test_an_unknown_device_raises_a_clear_error(device):
    with pytest.raises(ValueError, match="device"):
        make(2, device=device)


def test_no_device_keeps_the_numpy_env():
    envs = make(2)
    assert isinstance(envs.reset(seed=0)[0], np.ndarray)
