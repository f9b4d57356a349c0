"""RollingDisk-v0 for N disks in one compiled batch: the ``vector_entry_point`` of the ids."""

from __future__ import annotations

import os
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from rolling_disk_env import engine, pcg64
from rolling_disk_env.constants import INFO_SETS
from rolling_disk_env.envs.batch import DiskBatch, Outputs
from rolling_disk_env.envs.config import EnvConfig, checked_actions

_LOW_64 = (1 << 64) - 1
"""The low 64 bits of a Python int."""


class RollingDiskVectorEnv(VectorEnv):
    """N independent rolling disks stepped together by the compiled engine.

    Same arguments, spaces, rewards and ``info`` keys as :class:`~rolling_disk_env.envs.RollingDiskEnv`, batched as
    ``SyncVectorEnv`` batches them: every key at every step, each with its mask ``_key`` (all True but in SAME_STEP's
    ``final_info``, which holds the sub-environments that ended, and after ``reset(options={"reset_mask": mask})``,
    which holds those reset); reward terms are 0 where a sub-environment's info comes from a reset. Plus:

    Args:
        num_envs: N.
        max_episode_steps: truncation after this many steps (``gymnasium.make_vec`` passes the id's 500); None for
            no truncation.
        autoreset_mode: ``AutoresetMode.NEXT_STEP`` (default), ``SAME_STEP`` or ``DISABLED``, or its string value:
            as in ``SyncVectorEnv``. NEXT_STEP: the step after a sub-environment ends resets it, ignores its action
            and returns its first observation with reward 0. SAME_STEP: the step that ends an episode resets the
            sub-environment at once and returns the new episode's first observation, with the last one in
            ``info["final_obs"]`` and the last info in ``info["final_info"]`` (masks ``_final_obs``,
            ``_final_info``). DISABLED: ended sub-environments must be reset with
            ``reset(options={"reset_mask": mask})`` before they step again.
        info_keys: the info keys of a step (and of SAME_STEP's ``final_info``): ``"full"`` (default), every key of
            the single env's; or ``"training"``, ``"is_success"`` and ``"termination"`` alone (what autoreset, the
            success rate and the trainers read), the step then writing none of the other rows (state, energy,
            contact and normal forces, required friction, reward terms, sliding); a reset's info likewise. The
            drawn constants of ``params_ranges`` are in both sets.

    Sub-environment i is seeded with ``seed + i`` by ``reset(seed=seed)`` (or ``seed[i]`` from a list), as
    ``SyncVectorEnv`` does, and draws its episodes exactly as a single env with that seed would: both run the same
    compiled kernels, so the transitions are equal to the last bit. The seeds' PCG64 states are hashed in compiled code
    (:func:`rolling_disk_env.pcg64.seed_states`) for seeds below 2^128, by numpy one at a time above; the states are
    numpy's either way. ``reset(options={"state": X})`` takes initial states of shape (N, 8), or (N, 10) under the
    ``"sliding"`` and ``"coulomb"`` contacts. The batch steps vectorized over the disks; from
    ``rolling_disk_env.envs.batch.THREADS_FROM`` disks on numba's threads when they measure faster
    (``rolling_disk_env.envs.batch.ThreadChoice``; ``NUMBA_NUM_THREADS=1`` keeps it on one). Rendering is not offered:
    render one disk with the single env.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        render_mode: None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        info_keys: str = "full",
        **kwargs,
    ):
        if info_keys not in INFO_SETS:
            raise ValueError(f"info_keys must be one of {list(INFO_SETS)}, got {info_keys!r}")
        self.info_keys = info_keys
        if not (isinstance(num_envs, (int, np.integer)) and not isinstance(num_envs, bool) and num_envs >= 1):
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if max_episode_steps is not None and not (
            isinstance(max_episode_steps, (int, np.integer)) and max_episode_steps >= 1
        ):
            raise ValueError(f"max_episode_steps must be an integer >= 1 or None, got {max_episode_steps!r}")
        if render_mode is not None:
            raise ValueError("the vector env does not render; render a single RollingDisk-v0 instead")
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            modes = [mode.value for mode in AutoresetMode]
            raise ValueError(
                f"autoreset_mode must be an AutoresetMode or one of {modes}, got {autoreset_mode!r}"
            ) from None
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        self.config = EnvConfig.from_kwargs(**kwargs)
        self.task = self.config.task
        self.num_envs = int(num_envs)
        self.max_episode_steps = max_episode_steps
        self.render_mode = None
        self.dt = self.config.dt
        self.single_action_space = self.config.action_space
        self.single_observation_space = self.config.observation_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._batch = self._new_batch(max_episode_steps)
        self._rngs = np.zeros((self.num_envs, 4), dtype=np.uint64)
        self._seeded = False
        self._ended = np.zeros(self.num_envs, dtype=bool)
        self._last: Outputs | None = None  # the latest step's or reset's outputs
        self._term_keys = [f"reward_{name}" for name in self.task.reward_weights]

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        options = dict(options or {})
        mask = self._reset_mask(options.pop("reset_mask", None))
        states = self.config.reset_state(options, self.num_envs)
        self._seed(seed, mask)
        out = self._batch.outputs()
        if self._last is not None:
            # The others' latest observations, from the info block: the caller may have changed those it was given.
            out.observations[:] = self._last.info[self._batch.observation_rows].T
        self._batch.reset(mask, out, self._rngs, states)
        self._ended = self._ended & ~mask
        self._last = out
        return out.observations, self._infos(out, mask)  # fresh arrays, as the step's

    def _reset_mask(self, mask) -> np.ndarray:
        """``options["reset_mask"]`` checked as ``SyncVectorEnv`` checks it; all envs when it is absent."""
        if mask is None:
            return np.ones(self.num_envs, dtype=bool)
        if self._last is None:
            raise ValueError('options["reset_mask"] resets some sub-environments: reset all of them first')
        if not isinstance(mask, np.ndarray) or mask.shape != (self.num_envs,) or mask.dtype != np.bool_:
            got = f"{type(mask).__name__} {getattr(mask, 'shape', '')} {getattr(mask, 'dtype', '')}"
            raise ValueError(f'options["reset_mask"] must be a bool array of shape ({self.num_envs},), got {got}')
        if not mask.any():
            raise ValueError('options["reset_mask"] must hold at least one True')
        return mask

    def _seed(self, seed, mask: np.ndarray) -> None:
        """Seeds the PCG64 state of each sub-environment in ``mask`` as ``gymnasium.utils.seeding.np_random`` would:
        ``seed + i``, ``seed[i]``, or fresh entropy for None (once: later resets without a seed go on with the same
        streams, as a single env's do). A negative seed raises ``np_random``'s error."""
        if seed is None:
            if self._seeded:
                return
            seeds = None
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = range(int(seed), int(seed) + self.num_envs)
        elif isinstance(seed, (list, tuple)) and len(seed) == self.num_envs:
            seeds = seed
        else:
            raise ValueError(f"seed must be None, an int or a list of {self.num_envs} ints or None, got {seed!r}")
        self._set_rngs(*_seeded_words(seeds, mask, fresh=not self._seeded))
        self._seeded = True

    def _new_batch(self, max_episode_steps: int | None) -> DiskBatch:
        """The batch of the env's disks."""
        return DiskBatch(self.config, self.num_envs, max_episode_steps, self.info_keys)

    def _set_rngs(self, words: np.ndarray, mask: np.ndarray) -> None:
        """Sets the PCG64 states of the sub-environments in ``mask`` to those rows of ``words`` ((N, 4) uint64)."""
        np.copyto(self._rngs, words, where=mask[:, None])

    def _checked_actions(self, actions):
        """``actions`` as the batch steps them: a C-contiguous float32 array of the action space's shape."""
        if type(actions) is not np.ndarray or actions.dtype != np.float32 or not actions.flags.c_contiguous:
            return checked_actions(actions, self.action_space.shape, "actions")
        if actions.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {actions.shape}")
        return actions

    _kept = staticmethod(np.copy)
    """A copy of an output array that the next step does not change."""

    def step(self, actions):
        if self._last is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        actions = self._checked_actions(actions)
        mode = self.autoreset_mode
        if mode == AutoresetMode.DISABLED and self._ended.any():
            ended = [i for i, done in enumerate(self._ended.tolist()) if done]
            raise ValueError(
                f"sub-environments {ended} have ended and autoreset is disabled: "
                'reset them with reset(options={"reset_mask": mask}) first'
            )
        out = self._batch.outputs(zeroed=False)  # the step writes every column
        # Next-step autoreset: the step starts new episodes in the sub-environments that ended, in the same call.
        resetting = self._ended if mode == AutoresetMode.NEXT_STEP else None
        bad = self._batch.step(actions, out, resetting, self._rngs)
        if bad >= 0:
            raise ValueError(f"actions must be finite numbers, got {actions[bad].tolist()} for sub-environment {bad}")
        # Copies: views would keep the whole info block alive as long as the caller keeps them.
        rewards = self._kept(out.info[engine.REWARD])
        terminated, truncated = self._kept(out.flags[engine.TERMINATED]), self._kept(out.flags[engine.TRUNCATED])
        ended = terminated | truncated
        if mode == AutoresetMode.SAME_STEP and ended.any():
            final = self._final(out, ended)
            self._batch.reset(ended, out, self._rngs)
            infos = self._infos(out, None)
            infos.update(final)
        else:
            infos = self._infos(out, None)
            self._ended = ended
        self._last = out
        # The observations as they are: fresh arrays at every step, which the env reads no more (a reset takes the
        # latest ones from the info block).
        return out.observations, rewards, terminated, truncated, infos

    def _infos(self, out: Outputs, present: np.ndarray | None) -> dict:
        """The batched info of ``out``: every key of the env's ``info_keys``, each with its mask ``present`` (None:
        every sub-environment)."""
        info, first = out.info, self._batch.contact_rows
        mask = np.ones(self.num_envs, dtype=bool) if present is None else present
        disks = self._batch.lanes[engine.MASS : engine.MU + 1, : self.num_envs].copy()  # before a same-step reset
        if self.info_keys == "training":
            return self._masked_infos(out, None, None, None, disks, mask)
        if first is None:
            sliding, slip = np.zeros(self.num_envs, bool), np.zeros((self.num_envs, 2))
        else:
            sliding, slip = info[first + 4] > 0.0, info[first + 2 : first + 4].T
        return self._masked_infos(out, info[self._batch.state_rows].T, sliding, slip, disks, mask)

    def _masked_infos(self, out: Outputs, state, sliding, slip, disks, mask) -> dict:
        """The info keys of ``out`` (its rows as they are, but the ``state``, ``sliding`` flags and ``slip``
        velocities given, and the disks' constants ``disks``, (m, g, r, mu) rows, of which those drawn per episode
        are reported), each with its mask ``"_key"``: ``mask``. The training set (``state`` None) has the flags and
        codes alone, and the drawn constants."""
        info = out.info
        infos = {}
        if state is not None:
            infos = {
                "state": state,
                "energy": info[engine.ENERGY],
                "contact_force": info[engine.LAMBDA1 : engine.LAMBDA2 + 1].T,
                "normal_force": info[engine.NORMAL_FORCE],
                "required_friction": info[engine.REQUIRED_FRICTION],
                "sliding": sliding,
                "slip_velocity": slip,
            }
        infos["is_success"] = out.flags[engine.SUCCESS]
        infos["termination"] = out.codes  # RUNNING (0) where not terminated
        if state is not None:
            infos.update(zip(self._term_keys, info[engine.TERMS :]))
        for name, row in self._batch.drawn_rows:
            infos[name] = disks[row - engine.MASS]
        masked = {}
        for key, value in infos.items():
            masked[key], masked["_" + key] = value, mask
        return masked

    def _final(self, out: Outputs, ended: np.ndarray) -> dict:
        """SAME_STEP's ``final_obs`` and ``final_info`` of the sub-environments that ended, taken from ``out`` before
        they are reset."""
        final_obs = np.empty(self.num_envs, dtype=object)  # None everywhere
        for i in np.flatnonzero(ended).tolist():
            final_obs[i] = out.observations[i].copy()
        kept = Outputs.empty(self.num_envs, out.observations.shape[1], out.info.shape[0])
        kept.info[:, ended] = out.info[:, ended]
        kept.flags[:, ended] = out.flags[:, ended]
        kept.codes[ended] = out.codes[ended]
        final_info = self._infos(kept, ended)
        return {"final_obs": final_obs, "_final_obs": ended, "final_info": final_info, "_final_info": ended.copy()}


def _seeded_words(seeds, mask: np.ndarray, fresh: bool) -> tuple[np.ndarray, np.ndarray]:
    """The PCG64 states that ``gymnasium.utils.seeding.np_random(seeds[i])`` starts from, for the sub-environments i
    of ``mask``, as :func:`rolling_disk_env.pcg64.state_words` gives them.

    Args:
        seeds: a sequence of N seeds, each a non-negative int or None (fresh entropy); or None: fresh entropy for
            every one. A ``range`` (``reset(seed=s)``'s ``s + i``) of seeds from 0 to
            :data:`~rolling_disk_env.pcg64.SEED_LIMIT` is hashed without a Python loop.
        mask: (N,) bool, the sub-environments to seed.
        fresh: whether a None in ``seeds`` draws fresh entropy (else it leaves the sub-environment's state as it is).

    Returns:
        The states, (N, 4) uint64, and the mask (N,) of the rows that hold one.

    Seeds below ``SEED_LIMIT`` (2^128) and fresh entropy go through :func:`~rolling_disk_env.pcg64.seed_states`,
    larger seeds through numpy's ``SeedSequence``; ``np_random`` raises Gymnasium's error for the others.
    """
    n = len(mask)
    words, given = np.zeros((n, 4), dtype=np.uint64), np.zeros(n, dtype=bool)  # given: the states numpy gives
    offsets = np.zeros(n, dtype=np.uint64)
    if seeds is None:
        hashed, (highs, lows) = mask, _entropy(n)
    elif isinstance(seeds, range) and 0 <= seeds.start and seeds.stop <= pcg64.SEED_LIMIT:
        hashed, offsets = mask, np.arange(n, dtype=np.uint64)
        highs = np.full(n, seeds.start >> 64, dtype=np.uint64)
        lows = np.full(n, seeds.start & _LOW_64, dtype=np.uint64)
    else:
        rows, values, entropic = [], [], []
        for i in np.flatnonzero(mask).tolist():
            seed = seeds[i]
            if seed is None:
                if fresh:
                    entropic.append(i)
            elif isinstance(seed, int) and 0 <= seed < pcg64.SEED_LIMIT:
                rows.append(i)
                values.append(seed)
            else:
                words[i], given[i] = pcg64.state_words(seeding.np_random(seed)[0]), True
        highs, lows, hashed = np.zeros(n, dtype=np.uint64), np.zeros(n, dtype=np.uint64), np.zeros(n, dtype=bool)
        highs[rows], lows[rows] = [value >> 64 for value in values], [value & _LOW_64 for value in values]
        highs[entropic], lows[entropic] = _entropy(len(entropic))
        hashed[rows] = True
        hashed[entropic] = True
    pcg64.seed_states(highs, lows, offsets, hashed, words)
    return words, hashed | given


def _entropy(count: int) -> np.ndarray:
    """``count`` entropies as ``np.random.SeedSequence(None)`` draws one: 128 bits from the operating system
    (``secrets.randbits``, which reads ``os.urandom``); (2, count) uint64, the high and the low halves."""
    return np.frombuffer(os.urandom(16 * count), dtype=np.uint64).reshape(2, count)
