"""The native vector env: Gymnasium's vector API, its three autoreset modes against SyncVectorEnv, and equality with N
single envs to the last bit."""

import math
import os
import re

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import rolling_disk_env as rd
from rolling_disk_env import pcg64
from rolling_disk_env.envs import batch
from rolling_disk_env.tasks import TASKS

RANDOMIZED_DISKS = {"params_ranges": {"mass": (4.0, 6.0), "radius": (0.8, 1.2), "gravity": (9.0, 10.6)}}
THREADED = 512
"""A batch that the tests step on numba's threads."""
COULOMB = {"contact": "coulomb", "friction_coefficient": 0.2}
"""A contact on which the tasks' disks slide now and then."""
LIMIT = 60
"""Episode steps before truncation in these tests: short, so that every sub-environment is reset many times."""


def _native(num_envs, mode=AutoresetMode.NEXT_STEP, **kwargs):
    return gym.make_vec(
        rd.ENV_ID,
        num_envs=num_envs,
        vectorization_mode="vector_entry_point",
        max_episode_steps=LIMIT,
        autoreset_mode=mode,
        **kwargs,
    )


def _sync(num_envs, mode, **kwargs):
    return SyncVectorEnv(
        [lambda: gym.make(rd.ENV_ID, max_episode_steps=LIMIT, **kwargs) for _ in range(num_envs)],
        autoreset_mode=mode,
    )


def assert_infos_equal(ours: dict, theirs: dict, where: str = "info") -> None:
    """Same keys, dtypes, shapes and values, to the last bit (object arrays element by element)."""
    assert set(ours) == set(theirs), f"{where}: keys {sorted(set(ours) ^ set(theirs))} differ"
    for key, expected in theirs.items():
        value = ours[key]
        if isinstance(expected, dict):
            assert_infos_equal(value, expected, f"{where}[{key!r}]")
        elif expected.dtype == object:
            assert value.dtype == object and len(value) == len(expected)
            for a, b in zip(value, expected):
                if isinstance(b, np.ndarray):
                    np.testing.assert_array_equal(a, b, err_msg=f"{where}[{key!r}]")
                else:
                    assert a == b, f"{where}[{key!r}]: {value} != {expected}"
        else:
            assert value.dtype == expected.dtype, f"{where}[{key!r}]: dtype {value.dtype} != {expected.dtype}"
            np.testing.assert_array_equal(value, expected, err_msg=f"{where}[{key!r}]")


def _assert_transitions_equal(ours, theirs):
    for name, a, b in zip(("observation", "reward", "terminated", "truncated"), ours[:4], theirs[:4]):
        assert a.dtype == b.dtype, name
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert_infos_equal(ours[4], theirs[4])


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda mode: mode.value)
@pytest.mark.parametrize(
    "kwargs",
    [pytest.param({"task": task}, id=task) for task in sorted(TASKS)]
    + [pytest.param({"task": "goto", **COULOMB}, id="goto, coulomb")],
)
def test_each_autoreset_mode_behaves_exactly_like_sync_vector_env(kwargs, mode):
    # 1000 steps for the first three tasks, 300 for the later ones (their episodes end as often: by the limit of 60).
    num_envs, steps = 4, 1000 if kwargs["task"] in ("upright", "circle", "goto") else 300
    ours, theirs = _native(num_envs, mode, **kwargs), _sync(num_envs, mode, **kwargs)
    assert ours.autoreset_mode == ours.metadata["autoreset_mode"] == mode
    reset = ours.reset(seed=5), theirs.reset(seed=5)
    np.testing.assert_array_equal(reset[0][0], reset[1][0])
    assert_infos_equal(reset[0][1], reset[1][1])
    rng = np.random.default_rng(1)
    ends = 0
    for _ in range(steps):
        actions = rng.uniform(-1.2, 1.2, (num_envs, 2)).astype(np.float32)
        ours_step, theirs_step = ours.step(actions), theirs.step(actions)
        _assert_transitions_equal(ours_step, theirs_step)
        ended = ours_step[2] | ours_step[3]
        ends += ended.sum()
        if mode == AutoresetMode.DISABLED and ended.any():
            mask = ended.copy()
            a, b = ours.reset(options={"reset_mask": mask}), theirs.reset(options={"reset_mask": mask.copy()})
            np.testing.assert_array_equal(a[0], b[0])
            assert_infos_equal(a[1], b[1])
    assert ends >= num_envs * (steps // (LIMIT + 1))  # truncations alone give this many (a step to reset each)


def test_a_partial_reset_returns_the_latest_observations_even_where_the_caller_changed_them():
    # The step returns its observation array as it is (a fresh one at every step); a reset of some sub-environments
    # gives the others their latest observations from the env's own record, not from the array the caller holds.
    env = _native(4, AutoresetMode.DISABLED, task="circle")
    env.reset(seed=0)
    observations = env.step(np.full((4, 2), 0.5, np.float32))[0]
    latest = observations.copy()
    observations[:] = 99.0
    after, _ = env.reset(options={"reset_mask": np.array([True, False, False, False])})
    np.testing.assert_array_equal(after[1:], latest[1:])
    assert not np.array_equal(after[0], latest[0])


@pytest.mark.parametrize(
    ("kwargs", "num_envs", "compared"),
    [pytest.param({"task": task}, 5, range(5), id=task) for task in sorted(TASKS)]
    + [pytest.param({"task": task, **RANDOMIZED_DISKS}, 5, range(5), id=f"{task}, random disks") for task in TASKS]
    # A batch this large is split into shares, one a thread, padded (envs.batch), and fills the vectorized loop.
    + [pytest.param({"task": "circle"}, THREADED, (0, 1, THREADED // 2, THREADED - 1), id="circle, threads")]
    # The contact steps of the first three tasks, of ice (its own contact) and of a task with progress (their steps
    # share the templates of every task's: rolling_disk_env.codegen).
    + [
        pytest.param({"task": task, **COULOMB}, 5, range(5), id=f"{task}, coulomb")
        for task in ("circle", "goto", "ice", "upright", "waypoints")
    ]
    + [pytest.param({"task": "goto", "contact": "sliding"}, 5, range(5), id="goto, frozen lake")]
    + [pytest.param({"task": "circle", **COULOMB}, THREADED, (0, THREADED - 1), id="circle, coulomb, threads")],
)
def test_vector_env_equals_single_envs_to_the_last_bit(kwargs, num_envs, compared, monkeypatch):
    monkeypatch.setattr(batch, "THREADS_FROM", THREADED // 2)  # so that the large batch steps on threads
    steps = 300
    vector = _native(num_envs, **kwargs)
    observations, infos = vector.reset(seed=11)
    singles = {i: gym.make(rd.ENV_ID, max_episode_steps=LIMIT, **kwargs) for i in compared}
    for i, env in singles.items():
        observation, info = env.reset(seed=11 + i)
        np.testing.assert_array_equal(observations[i], observation)
        np.testing.assert_array_equal(infos["state"][i], info["state"])
    rng = np.random.default_rng(0)
    done = np.zeros(num_envs, dtype=bool)
    resets = slid = 0
    for _ in range(steps):
        actions = rng.uniform(-1.2, 1.2, (num_envs, 2)).astype(np.float32)
        observations, rewards, terminated, truncated, infos = vector.step(actions)
        for i, env in singles.items():
            if done[i]:
                observation, info = env.reset()
                reward, term, trunc = 0.0, False, False
                resets += 1
            else:
                observation, reward, term, trunc, info = env.step(actions[i])
            np.testing.assert_array_equal(observations[i], observation)
            assert (rewards[i], terminated[i], truncated[i]) == (reward, term, trunc)
            np.testing.assert_array_equal(infos["state"][i], info["state"])
            np.testing.assert_array_equal(infos["slip_velocity"][i], info["slip_velocity"])
            assert infos["energy"][i] == info["energy"] and infos["is_success"][i] == info["is_success"]
            assert infos["sliding"][i] == info["sliding"]
            slid += info["sliding"]
        done = terminated | truncated
    if kwargs.get("contact"):
        assert slid > 0  # the contact is put to work
    assert resets >= len(singles) * steps // LIMIT - len(singles)
    if vector._batch.threads > 1:  # some steps ran on the threads (engine.step_shares), calling the single env's step
        assert math.isfinite(vector._batch.choice.seconds[True])


def test_vector_spaces_and_types():
    vector = rd.RollingDiskVectorEnv(num_envs=3, max_episode_steps=10)
    observations, _ = vector.reset(seed=0)
    assert observations.shape == (3, 4) and observations.dtype == np.float32
    assert observations in vector.observation_space
    assert vector.action_space.shape == (3, 2)
    observations, rewards, terminated, truncated, infos = vector.step(vector.action_space.sample())
    assert rewards.dtype == np.float64 and terminated.dtype == bool and truncated.dtype == bool
    assert infos["state"].shape == (3, 8) and infos["contact_force"].shape == (3, 2)
    np.testing.assert_allclose(infos["energy"], rd.energy(infos["state"]), rtol=1e-12)


def test_autoreset_mode_takes_the_enum_or_its_string_value():
    assert rd.RollingDiskVectorEnv(num_envs=2, autoreset_mode="SameStep").autoreset_mode == AutoresetMode.SAME_STEP
    with pytest.raises(ValueError, match="autoreset_mode"):
        rd.RollingDiskVectorEnv(num_envs=2, autoreset_mode="sometimes")


def test_disabled_autoreset_refuses_to_step_an_ended_episode():
    vector = rd.RollingDiskVectorEnv(num_envs=2, max_episode_steps=1, autoreset_mode=AutoresetMode.DISABLED)
    vector.reset(seed=0)
    vector.step(np.zeros((2, 2), dtype=np.float32))
    with pytest.raises(ValueError, match="reset_mask"):
        vector.step(np.zeros((2, 2), dtype=np.float32))


def test_vector_reset_takes_exact_states_and_seed_lists():
    vector = rd.RollingDiskVectorEnv(num_envs=2, task="circle")
    states = np.array([[1, 2, 0, 0.1, 0, 2, 0, 0], [0, 0, 1, -0.2, 1, 3, 0, 0.5]], dtype=float)
    _, infos = vector.reset(seed=[5, 9], options={"state": states})
    np.testing.assert_array_equal(infos["state"], states)
    with pytest.raises(ValueError, match="shape"):
        vector.reset(options={"state": states[0]})
    with pytest.raises(ValueError, match="seed"):
        vector.reset(seed=[1, 2, 3])


class NumpySeeded(rd.RollingDiskVectorEnv):
    """The vector env as it seeded before seeds were hashed in compiled code: numpy's SeedSequence through
    ``gymnasium.utils.seeding.np_random``, a sub-environment at a time."""

    def _seed(self, seed, mask):
        if seed is None:
            if self._seeded:
                return
            seeds = [None] * self.num_envs
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
        rows = [i for i in np.flatnonzero(mask).tolist() if seeds[i] is not None or not self._seeded]
        words = [pcg64.state_words(seeding.np_random(seeds[i])[0]) for i in rows]
        if rows:
            self._rngs[rows] = words
        self._seeded = True


SEEDED_RESETS = [
    (0, None),
    (2**32 - 1, None),
    (2**63, None),
    (2**64 - 3, None),  # seed + i reaches 2^64 at i = 3: a third 32-bit word
    ([5, None, 2**64, 2**200, 0, None, True, 2**128 - 1], None),  # None: the stream goes on; 2^200: numpy's path
    (None, None),  # no new seeds
    (2**128 - 5, None),  # seed + i reaches 2^128 at i = 5
    (-2, [False, False, True, True, False, True, False, True]),  # the seeds of the mask's rows are not negative
    (77, [True, False, False, False, False, False, False, True]),
]


def test_seeded_resets_start_the_episodes_of_numpys_seed_sequences():
    num_envs = 8
    ours, theirs = (env(num_envs=num_envs, task="goto") for env in (rd.RollingDiskVectorEnv, NumpySeeded))
    for seed, mask in SEEDED_RESETS:
        options = None if mask is None else {"reset_mask": np.array(mask)}
        observations, infos = ours.reset(seed=seed, options=options)
        expected, expected_infos = theirs.reset(seed=seed, options=options)
        np.testing.assert_array_equal(ours._rngs, theirs._rngs, err_msg=str(seed))
        np.testing.assert_array_equal(observations, expected, err_msg=str(seed))
        assert_infos_equal(infos, expected_infos, f"seed={seed}")


@pytest.mark.parametrize("seed", [-1, -5, [1, -2, 3, 4], [1, np.int64(2), 3, 4], [None, 1.5, 0, 0]])
def test_negative_and_non_int_seeds_raise_gymnasiums_error_and_seed_nothing(seed):
    ours, theirs = rd.RollingDiskVectorEnv(num_envs=4), NumpySeeded(num_envs=4)
    ours.reset(seed=9)
    before = ours._rngs.copy()
    with pytest.raises(gym.error.Error) as expected:
        theirs.reset(seed=seed)
    with pytest.raises(type(expected.value), match=f"^{re.escape(str(expected.value))}$"):
        ours.reset(seed=seed)
    np.testing.assert_array_equal(ours._rngs, before)


def test_fresh_entropy_seeds_as_a_seed_sequence_of_128_random_bits(monkeypatch):
    num_envs = 3
    entropy = np.random.default_rng(0).integers(0, 2**64, (2, num_envs), dtype=np.uint64, endpoint=False)
    urandom = os.urandom
    monkeypatch.setattr(os, "urandom", lambda size: entropy.tobytes() if size == entropy.nbytes else urandom(size))
    ours, theirs = rd.RollingDiskVectorEnv(num_envs=num_envs), NumpySeeded(num_envs=num_envs)
    observations, _ = ours.reset()
    expected, _ = theirs.reset(seed=[high << 64 | low for high, low in entropy.T.tolist()])
    np.testing.assert_array_equal(ours._rngs, theirs._rngs)
    np.testing.assert_array_equal(observations, expected)


def test_step_before_reset_raises_reset_needed():
    with pytest.raises(gym.error.ResetNeeded):
        rd.RollingDiskVectorEnv(num_envs=2).step(np.zeros((2, 2), dtype=np.float32))


@pytest.mark.parametrize(
    ("actions", "message"),
    [
        (np.full((2, 2), np.nan, dtype=np.float32), "finite"),
        (np.array([[0, 0], [0, np.inf]]), "finite"),
        (np.zeros((2, 3), dtype=np.float32), "shape"),
        (np.zeros(2, dtype=np.float32), "shape"),
        (np.ones((2, 2), dtype=bool), "actions must be finite numbers .*bool"),
        (np.ones((2, 2), dtype=np.complex64), "actions must be finite numbers .*complex64"),
    ],
)
def test_vector_bad_actions_raise_and_step_nothing(actions, message):
    vector = rd.RollingDiskVectorEnv(num_envs=2)
    _, infos = vector.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        vector.step(actions)
    np.testing.assert_array_equal(vector._batch.states.T, infos["state"])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"num_envs": 0}, "num_envs"), ({"max_episode_steps": 0}, "max_episode_steps"), ({"task": "x"}, "task")],
)
def test_vector_bad_arguments_raise(kwargs, message):
    with pytest.raises(ValueError, match=message):
        rd.RollingDiskVectorEnv(**{"num_envs": 2, **kwargs})


@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda mode: mode.value)
def test_every_info_key_is_there_for_every_sub_environment_at_every_step(mode):
    num_envs = 4
    vector = _native(num_envs, mode, task="upright")
    _, infos = vector.reset(seed=0)
    keys = set(infos)
    assert {f"reward_{term}" for term in vector.unwrapped.task.reward_weights} | {"termination"} <= keys

    def check(infos, terminated, reported=None):
        reported = np.ones(num_envs, dtype=bool) if reported is None else reported
        assert set(infos) - {"final_obs", "_final_obs", "final_info", "_final_info"} == keys
        for key in keys:
            if key.startswith("_"):  # every sub-environment, or those a partial reset reports, as SyncVectorEnv
                np.testing.assert_array_equal(infos[key], reported, err_msg=key)
        # A passive upright disk falls (its lean beyond 0.5 rad): that is the only termination here. SAME_STEP
        # reports it in the final info; the info beside it is the next episode's first.
        expected = np.where(terminated, rd.Termination.FALLEN, rd.Termination.NONE)
        if mode == AutoresetMode.SAME_STEP and terminated.any():
            np.testing.assert_array_equal(infos["final_info"]["termination"], expected)
            expected = np.zeros(num_envs, dtype=np.int64)
        assert infos["termination"].dtype == np.int64
        np.testing.assert_array_equal(infos["termination"], expected)

    check(infos, np.zeros(num_envs, dtype=bool))
    terminations = 0
    for _ in range(3 * LIMIT):
        _, _, terminated, truncated, infos = vector.step(np.zeros((num_envs, 2), dtype=np.float32))
        check(infos, terminated)
        terminations += terminated.sum()
        if mode == AutoresetMode.DISABLED and (terminated | truncated).any():
            _, infos = vector.reset(options={"reset_mask": terminated | truncated})
            check(infos, np.zeros(num_envs, dtype=bool), terminated | truncated)
    assert terminations > 0


@pytest.mark.parametrize(
    "kwargs", [{"task": "circle"}, {"task": "goto", **COULOMB}], ids=["circle", "goto, coulomb"]
)  # circle's training steps: those of the manual's torch example too (docs/gpu.md), compiled once
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP], ids=lambda mode: mode.value)
def test_the_training_info_set_gives_the_full_sets_outputs_to_the_last_bit(kwargs, mode):
    # info_keys="training": the step's variant that writes no state, contact or reward-term rows; the observations,
    # rewards, flags, success and codes are the full step's, bit for bit, and so are SAME_STEP's final ones.
    full, training = _native(16, mode, **kwargs), _native(16, mode, info_keys="training", **kwargs)
    for env in (full, training):
        env.reset(seed=3)
    rng = np.random.default_rng(4)
    for _ in range(120):
        actions = rng.uniform(-1.2, 1.2, (16, 2)).astype(np.float32)
        a, b = full.step(actions), training.step(actions)
        for index in range(4):
            np.testing.assert_array_equal(a[index], b[index])
        final = {"final_obs", "_final_obs", "final_info", "_final_info"}
        assert set(b[4]) - final == {"is_success", "_is_success", "termination", "_termination"}
        for key in ("is_success", "termination"):
            np.testing.assert_array_equal(a[4][key], b[4][key])
        if "final_info" in a[4]:
            for key in ("is_success", "termination"):
                np.testing.assert_array_equal(a[4]["final_info"][key], b[4]["final_info"][key])
            assert set(b[4]["final_info"]) == {"is_success", "_is_success", "termination", "_termination"}
