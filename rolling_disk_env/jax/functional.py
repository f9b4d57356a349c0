"""The JAX tasks the Gymnasium way: ``gymnasium.make("RollingDiskJax-v0", task=...)`` and its ``make_vec``.

Gymnasium's functional API splits an env into pure functions of a state (``FuncEnv``: ``initial``, ``transition``,
``observation``, ``reward``, ``terminal``), and its ``FunctionalJaxEnv`` and ``FunctionalJaxVectorEnv`` make a
Gymnasium env of them, jitted (the vector one also vmapped over the disks), whose observations are JAX arrays.
:class:`RollingDiskFunctional` is that ``FuncEnv`` over :class:`~rolling_disk_env.jax.env.RollingDiskJax`'s step, the
same kernels, with nothing computed twice: its state is one array a disk (Gymnasium's vector env starts episodes with
``state.at[disks].set(...)``, an array's method), holding the gymnax state's fields and then the step's reward,
termination code and ``info`` values (:attr:`RollingDiskFunctional.layout`), so that ``reward``, ``terminal`` and
the step's info read what ``transition`` computed.

What differs from ``RollingDisk-v0``: observations, rewards and info are JAX arrays; the reset's info is empty; no
rendering; the tasks' scope in JAX (the ``"rolling"`` contact, the fixed-step integrators: ValueError otherwise).
Truncation is Gymnasium's: ``TimeLimit`` for ``gymnasium.make``, the vector env's own step count for ``make_vec``
(500 steps, the registered ids' limit). For training and differentiation in JAX, :class:`RollingDiskJax` (gymnax's
API) is the interface: this one serves code written for Gymnasium's.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium.envs.functional_jax_env import FunctionalJaxEnv, FunctionalJaxVectorEnv
from gymnasium.experimental.functional import FuncEnv
from gymnasium.utils import EzPickle

from rolling_disk_env import engine
from rolling_disk_env.envs.config import DRAWN
from rolling_disk_env.jax.env import EnvParams, EnvState, RollingDiskJax

REPORTED = ("energy", "contact_force", "normal_force", "required_friction")
"""The info entries of a step kept in the state, after its reward and code (then the reward terms)."""


class RollingDiskFunctional(FuncEnv):
    """A task of ``RollingDisk-v0`` as Gymnasium's ``FuncEnv``, over :class:`RollingDiskJax`.

    Args:
        task: a key of :data:`rolling_disk_env.TASK_IDS`.
        **kwargs: :class:`RollingDiskJax`'s (the Gymnasium env's keyword arguments).

    Attributes:
        gymnax: the :class:`RollingDiskJax` whose step this is.
        layout: where each part of a disk's state array lies, name -> slice: ``x``, ``goal``, ``disk``, ``success``,
            ``tracking_sum``, ``tracking_weight``, ``time`` (the gymnax state), then the latest step's ``reward`` and
            ``termination`` code and the info values of :data:`REPORTED` and the reward ``terms``.
        size: the length of a disk's state array.
    """

    def __init__(self, task: str = "upright", **kwargs: Any):
        self.gymnax = RollingDiskJax(task, **kwargs)
        super().__init__()
        params = self.default_params
        high = np.asarray(params.observation_high, np.float32)
        self.observation_space = gymnasium.spaces.Box(-high, high, dtype=np.float32)
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (self.gymnax.num_actions,), np.float32)
        sizes = {
            "x": 8,
            "goal": self.gymnax.task.goal_size,
            "disk": 3,
            **dict.fromkeys(("success", "tracking_sum", "tracking_weight", "time", "reward", "termination"), 1),
            "energy": 1,
            "contact_force": 2,
            "normal_force": 1,
            "required_friction": 1,
            "terms": len(self.gymnax.term_keys),
        }
        ends = np.cumsum(list(sizes.values()))
        self.layout = {name: slice(end - size, end) for (name, size), end in zip(sizes.items(), ends, strict=True)}
        self.size = int(ends[-1])

    def get_default_params(self, **kwargs: Any) -> EnvParams:
        """The gymnax env's :attr:`~RollingDiskJax.default_params`."""
        return self.gymnax.default_params

    def _pack(self, state: EnvState, reward, code, info: dict | None) -> jax.Array:
        """The state array of a disk: ``state``'s fields, then the step's reward, code and ``info`` values (zeros
        where ``info`` is None: at a reset)."""
        dtype = state.x.dtype
        parts = {
            "x": state.x,
            "goal": state.goal,
            "disk": state.disk,
            "success": state.success,
            "tracking_sum": state.tracking_sum,
            "tracking_weight": state.tracking_weight,
            "time": state.time,
            "reward": reward,
            "termination": code,
        }
        if info is not None:
            parts.update({name: info[name] for name in REPORTED})
            parts["terms"] = jnp.stack([info[key] for key in self.gymnax.term_keys])
        flat = jnp.zeros(self.size, dtype)
        for name, value in parts.items():
            flat = flat.at[self.layout[name]].set(jnp.ravel(jnp.asarray(value, dtype)))
        return flat

    def _part(self, state: jax.Array, name: str) -> jax.Array:
        """A part of state arrays (one disk's or a batch's: the last axis): a value, or a vector for ``x``, ``goal``,
        ``disk``, ``contact_force`` and ``terms``."""
        part = state[..., self.layout[name]]
        return part if name in ("x", "goal", "disk", "contact_force", "terms") else part[..., 0]

    def _unpack(self, state: jax.Array) -> EnvState:
        """The gymnax state of a disk's state array."""
        return EnvState(
            x=self._part(state, "x"),
            goal=self._part(state, "goal"),
            disk=self._part(state, "disk"),
            success=self._part(state, "success") != 0,
            tracking_sum=self._part(state, "tracking_sum"),
            tracking_weight=self._part(state, "tracking_weight"),
            time=self._part(state, "time").astype(jnp.int32),
        )

    def initial(self, rng: jax.Array, params: EnvParams | None = None) -> jax.Array:
        """A new episode drawn from ``rng`` (:meth:`RollingDiskJax.reset_env`)."""
        _, state = self.gymnax.reset_env(rng, params or self.default_params)
        return self._pack(state, 0.0, engine.RUNNING, None)

    def transition(self, state: jax.Array, action: jax.Array, rng: jax.Array, params=None) -> jax.Array:
        """One control period (:meth:`RollingDiskJax.step_env`), its reward, code and info kept in the state."""
        _, new, reward, _, info = self.gymnax.step_env(rng, self._unpack(state), action, params or self.default_params)
        return self._pack(new, reward, info["termination"], info)

    def observation(self, state: jax.Array, rng: jax.Array, params: EnvParams | None = None) -> jax.Array:
        """The task's observation of the disk, float32, clipped to its bounds."""
        x, goal, disk = self._part(state, "x"), self._part(state, "goal"), self._part(state, "disk")
        return self.gymnax._observation(tuple(x), tuple(goal), tuple(disk), params or self.default_params)

    def reward(self, state, action, next_state: jax.Array, rng, params=None) -> jax.Array:
        """The reward of the step that led to ``next_state``."""
        return self._part(next_state, "reward")

    def terminal(self, state: jax.Array, rng: jax.Array, params: EnvParams | None = None) -> jax.Array:
        """Whether the step that led to ``state`` ended its episode (fell, left the model's domain, slipped, reached
        the goal: a termination code other than RUNNING)."""
        return self._part(state, "termination") != engine.RUNNING

    def state_info(self, state: jax.Array, params: EnvParams | None = None) -> dict:
        """The reset's info: empty."""
        return {}

    def transition_info(self, state, action, next_state: jax.Array, params=None) -> dict:
        """The step's info, with the keys of ``RollingDisk-v0``'s (Gymnasium calls this one untransformed: it reads a
        disk's state array or a batch's alike)."""
        code, terms = self._part(next_state, "termination"), self._part(next_state, "terms")
        info = {
            "state": self._part(next_state, "x"),
            **{name: self._part(next_state, name) for name in REPORTED},
            "sliding": jnp.zeros(code.shape, bool),
            "slip_velocity": jnp.zeros((*code.shape, 2), next_state.dtype),
            "is_success": self._part(next_state, "success") != 0,
            "termination": code.astype(jnp.int32),
        }
        for j, key in enumerate(self.gymnax.term_keys):
            info[key] = terms[..., j]
        disk = self._part(next_state, "disk")
        for name in self.gymnax.config.drawn_names:
            info[name] = disk[..., DRAWN.index(name)]
        return info


class RollingDiskJaxEnv(FunctionalJaxEnv, EzPickle):
    """``gymnasium.make("RollingDiskJax-v0", task=...)``: :class:`RollingDiskFunctional`, jitted, one disk."""

    metadata: ClassVar[dict] = {"render_modes": [], "jax": True}

    def __init__(self, render_mode: str | None = None, **kwargs: Any):
        EzPickle.__init__(self, render_mode=render_mode, **kwargs)
        env = RollingDiskFunctional(**kwargs)
        env.transform(jax.jit)
        FunctionalJaxEnv.__init__(self, env, metadata=self.metadata, render_mode=render_mode)


class RollingDiskJaxVectorEnv(FunctionalJaxVectorEnv, EzPickle):
    """``gymnasium.make_vec("RollingDiskJax-v0", num_envs, vectorization_mode="vector_entry_point", task=...)``:
    :class:`RollingDiskFunctional`, jitted and vmapped over ``num_envs`` disks, next-step autoreset, truncating at
    ``max_episode_steps``."""

    metadata: ClassVar[dict] = {
        "render_modes": [],
        "jax": True,
        "autoreset_mode": gymnasium.vector.AutoresetMode.NEXT_STEP,
    }

    def __init__(self, num_envs: int, render_mode: str | None = None, max_episode_steps: int = 500, **kwargs: Any):
        EzPickle.__init__(self, num_envs, render_mode=render_mode, max_episode_steps=max_episode_steps, **kwargs)
        env = RollingDiskFunctional(**kwargs)
        env.transform(jax.jit)
        FunctionalJaxVectorEnv.__init__(
            self, env, num_envs, max_episode_steps=max_episode_steps, metadata=self.metadata, render_mode=render_mode
        )
