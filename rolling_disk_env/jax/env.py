"""The tasks of RollingDisk-v0 as gymnax environments: pure, jit-compiled, vmap-able and differentiable.

:class:`RollingDiskJax` is a gymnax ``Environment`` (the 1.0 API: ``step`` returns ``(obs, state, reward,
terminated, truncated, info)`` and resets the episodes that end in the same call, ``info["final_observation"]``
holding the observation they ended on). Its step is the engine's control period (``_generated/<task>.py``'s step,
in the same order): the action's torques, the integrator's substeps, the domain check, the contact check, the
task's termination, reward terms, observation and success (the task's success rule: SURVIVE, TRACK with its two
running sums in :class:`EnvState`, or REACH). Every formula in it is a kernel of the package read as
JAX (:mod:`rolling_disk_env.jax.reading`): the model's generated steps, the engine's checks and the task's formulas,
so the physics and the tasks exist once.

What is supported: every task; the ``"rolling"`` contact (with ``friction_coefficient``: ``SLIPPED`` where the
contact needs more); the fixed-step integrators ``"euler"``, ``"symplectic_euler"`` and ``"rk4"`` with any
``substeps``. Not (``ValueError``): ``"dopri5"`` (its step size is carried from period to period and its
steps are accepted or rejected in a loop of data-dependent length; a ``lax.while_loop`` would express it, but not
differentiably by reverse mode, and its numba kernels, loops with early exits, have no JAX reading), the
``"sliding"`` and ``"coulomb"`` contacts (event location by bisection and mode switching, loops of data-dependent
length in the engine), and with them the task ``ice``, which runs under Coulomb's contact. ``params_ranges`` (the
mass, gravity and radius) is drawn at each reset from the env's own PRNG (:attr:`EnvParams.disk_ranges`; the
episode's disk is in :attr:`EnvState.disk` and in the step's ``info``); a task's progress
(:attr:`rolling_disk_env.tasks.Task.progress_names`) is part of :attr:`EnvState.goal`, which the step updates.
"""

from __future__ import annotations

import inspect
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct
from gymnax.environments import environment, spaces

import rolling_disk_env as rd
from rolling_disk_env import engine
from rolling_disk_env._generated import kernels
from rolling_disk_env.envs.config import DRAWN, EnvConfig
from rolling_disk_env.jax.reading import traced
from rolling_disk_env.tasks.base import REACH, TRACK

FIXED_STEP_METHODS = ("euler", "symplectic_euler", "rk4")
"""The integrators with a JAX reading."""


@struct.dataclass
class EnvState(environment.EnvState):
    """One disk's episode.

    Attributes:
        x: the state ``(c1, c2, phi, theta, psi, dphi, dtheta, dpsi)``, m, rad, m/s, rad/s.
        goal: the episode's targets (the task's ``goal_names``), then its progress (``progress_names``), which the
            step updates.
        disk: the episode's disk ``(m, g, r)``, kg, m/s^2, m (drawn at the reset from :attr:`EnvParams.disk_ranges`).
        success: whether the episode counts as a success if it ended now (``info["is_success"]``).
        tracking_sum: the success rule TRACK's exponentially weighted sum of the task's ``tracking_error`` over the
            episode's steps (its unit: m for ``circle``), zero at the reset (:func:`rolling_disk_env.engine.track`;
            the engine's row TRACKING_SUM). Zero throughout under the other rules.
        tracking_weight: the sum of its weights, dimensionless (the engine's row TRACKING_WEIGHT): the ratio
            ``tracking_sum / tracking_weight`` is the error's exponentially weighted mean.
        time: steps since the episode started.
    """

    x: jax.Array
    goal: jax.Array
    disk: jax.Array
    success: jax.Array
    tracking_sum: jax.Array
    tracking_weight: jax.Array
    time: int


@struct.dataclass
class EnvParams(environment.EnvParams):
    """A disk, its actuators and the task's options: what a step reads. Every field but the last three is a leaf
    of the pytree (``vmap`` over disks of different sizes, domain randomization); the last three shape the compiled
    program.

    Attributes:
        mass: m, kg.
        gravity: g, m/s^2.
        radius: r, m.
        disk_ranges: None (the disk above in every episode), or (3, 2): the uniform ranges ``(low, high)`` of m, g
            and r, drawn at each reset (``params_ranges``; a row with low = high keeps that constant).
        dt: the control period, s.
        max_torques: (spin, steer) torque of action +1, N m.
        friction_coefficient: the contact's mu (inf: ideal rolling); a step whose contact needs more ends with
            ``SLIPPED``.
        settings: the task's options its formulas read (its ``setting_names``).
        reward_weights: the weights of the task's reward terms, in their order.
        ranges: (draws, 2) the uniform ranges of the task's goal, then of its initial state.
        observation_high: the observation's bounds (clipped to them).
        success_bound: the success rule TRACK's bound on the tracking error's weighted mean, in the error's unit (m
            for ``circle``); the other rules do not read it.
        success_decay: the success rule TRACK's weight of the previous step's sums, ``exp(-dt / tau)`` with the
            task's ``success_time_constant`` tau (s), dimensionless; the other rules do not read it. It is computed
            for ``dt``: replace the two together.
        max_steps_in_episode: steps before truncation (500: 10 s, as ``gymnasium.make``'s TimeLimit).
        substeps: integrator steps per control period.
        integrator: ``"euler"``, ``"symplectic_euler"`` or ``"rk4"``.
        actuators: the torque each action component drives (0 spin, 1 steer).
    """

    mass: float = 5.0
    gravity: float = 9.81
    radius: float = 1.0
    disk_ranges: Any = None
    dt: float = 0.02
    max_torques: Any = None
    friction_coefficient: float = float("inf")
    settings: Any = None
    reward_weights: Any = None
    ranges: Any = None
    observation_high: Any = None
    success_bound: float = float("inf")
    success_decay: float = 1.0
    max_steps_in_episode: int = rd.MAX_EPISODE_STEPS
    substeps: int = struct.field(pytree_node=False, default=1)
    integrator: str = struct.field(pytree_node=False, default="rk4")
    actuators: tuple[int, ...] = struct.field(pytree_node=False, default=(0, 1))


class RollingDiskJax(environment.Environment[EnvState, EnvParams]):
    """A task of RollingDisk-v0 for JAX: the Gymnasium env's observations, rewards, terminations, truncation and
    ``info`` keys (as arrays), from the same kernels.

    Args:
        task: a key of :data:`rolling_disk_env.TASK_IDS`.
        **kwargs: the Gymnasium env's keyword arguments (``dt``, ``integrator``, ``substeps``, ``params``,
            ``friction_coefficient``, ``max_spin_torque``, ``max_steer_torque``, ``actuators``, ``initial_ranges``,
            ``task_options``), checked by the same code; they make :attr:`default_params`.

    Example:
        ``env = RollingDiskJax("upright"); params = env.default_params; obs, state = env.reset(key, params)``,
        then ``env.step(key, state, action, params)``; ``jax.vmap`` both over keys for a batch.
    """

    _supports_transition_gradients = True

    def __init__(self, task: str = "upright", **kwargs):
        super().__init__()
        self.config = config = EnvConfig.from_kwargs(task=task, **kwargs)
        if config.integrator not in FIXED_STEP_METHODS:
            raise ValueError(
                f"integrator must be one of {list(FIXED_STEP_METHODS)} in JAX (fixed steps), got {config.integrator!r}"
            )
        if config.task.contact not in (None, "rolling"):
            raise ValueError(
                f"task {task!r} runs under contact={config.task.contact!r} (Coulomb's contact: sliding and rolling by "
                "turns), which JAX does not have; run it on the numba env (CPU, or device='cuda')"
            )
        if config.contact != "rolling":
            raise ValueError(f"contact must be 'rolling' in JAX, got {config.contact!r}")
        module = inspect.getmodule(type(config.task))
        self.task = config.task
        self._start = traced(module.start)
        self._advance = traced(module.advance) if self.task.progress_names else None
        self._observe = traced(module.observe)
        self._reward_terms = traced(module.reward_terms)
        self._termination = traced(module.termination)
        if self.task.success == TRACK:
            self._tracking_error = traced(module.tracking_error)
            self._track = traced(engine.track)
        self._angles = traced(kernels.angles)
        self._contact = traced(engine.contact)
        self._contact_status = traced(engine.contact_status)
        self._in_domain = traced(engine.in_domain)
        self._centre_velocity = traced(engine.centre_velocity)
        self._steps = {method: traced(getattr(kernels, f"state_{method}_step_from")) for method in FIXED_STEP_METHODS}
        self.term_keys = tuple(f"reward_{name}" for name in config.task.reward_weights)

    @property
    def name(self) -> str:
        return rd.TASK_IDS[self.task.name]

    @property
    def num_actions(self) -> int:
        return len(self.config.actuators)

    @property
    def default_params(self) -> EnvParams:
        """The Gymnasium env's settings of the keyword arguments given, as arrays in JAX's default float type; the
        friction coefficient and the success rule's bound and decay are the entries of the engine's ``config``."""
        config = self.config
        m, g, r = config.params.constants
        engine_config = config.engine_config(None)
        ranges = config.disk_ranges[:3, :2]
        return EnvParams(
            mass=m,
            gravity=g,
            radius=r,
            disk_ranges=jnp.asarray(ranges) if config.params_ranges else None,
            dt=config.dt,
            max_torques=jnp.asarray(config.max_torque),
            friction_coefficient=float(engine_config[engine.FRICTION]),
            settings=jnp.asarray(self.task.settings),
            reward_weights=jnp.asarray(self.task.weights),
            ranges=jnp.asarray(config.ranges),
            observation_high=jnp.asarray(self.task.observation_high),
            success_bound=float(engine_config[engine.SUCCESS_BOUND]),
            success_decay=float(engine_config[engine.SUCCESS_DECAY]),
            max_steps_in_episode=rd.TASK_MAX_STEPS[self.task.name],
            substeps=config.substeps,
            integrator=config.integrator,
            actuators=tuple(int(row) for row in config.actuators_array[:, 0]),
        )

    def action_space(self, params: EnvParams | None = None) -> spaces.Box:
        """One normalized torque per actuator, in [-1, 1]."""
        return spaces.Box(-1.0, 1.0, (self.num_actions,), jnp.float32)

    def observation_space(self, params: EnvParams) -> spaces.Box:
        high = jnp.asarray(params.observation_high, jnp.float32)
        return spaces.Box(-high, high, high.shape, jnp.float32)

    def reset_env(self, key: jax.Array, params: EnvParams) -> tuple[jax.Array, EnvState]:
        """A new episode: the disk drawn from :attr:`EnvParams.disk_ranges` (from ``fold_in(key, 1)``), then the
        goal and the initial state from uniforms in the task's ranges (from ``key``)."""
        dtype = jnp.asarray(params.ranges).dtype
        uniforms = jax.random.uniform(key, (params.ranges.shape[0],), dtype)
        drawn = params.ranges[:, 0] + (params.ranges[:, 1] - params.ranges[:, 0]) * uniforms
        disk = self.draw_disk(key, params)
        goal, x = self._start(drawn, tuple(disk), tuple(params.settings))
        return self.start_from(jnp.stack(x), jnp.stack(goal), params, disk)

    def draw_disk(self, key: jax.Array, params: EnvParams) -> jax.Array:
        """The episode's disk ``(m, g, r)``: :attr:`EnvParams.mass` and the others, or where
        :attr:`EnvParams.disk_ranges` is set, uniform in its ranges (from ``fold_in(key, 1)``)."""
        fixed = jnp.stack(jnp.broadcast_arrays(params.mass, params.gravity, params.radius)).astype(
            jnp.result_type(float)
        )
        if params.disk_ranges is None:
            return fixed
        low, high = params.disk_ranges[:, 0], params.disk_ranges[:, 1]
        return low + (high - low) * jax.random.uniform(jax.random.fold_in(key, 1), (3,), fixed.dtype)

    def start_from(
        self, x: jax.Array, goal: jax.Array, params: EnvParams, disk: jax.Array | None = None
    ) -> tuple[jax.Array, EnvState]:
        """An episode from the state ``x``, the goal ``goal`` (targets and progress) and the disk ``disk`` ((m, g, r);
        None: :attr:`EnvParams.mass` and the others), as ``reset(options={"state": x})`` with the goal drawn: its
        first observation and state."""
        dtype = jnp.result_type(float)
        x, goal = jnp.asarray(x, dtype), jnp.asarray(goal, dtype)
        if disk is None:
            disk = jnp.stack(jnp.broadcast_arrays(params.mass, params.gravity, params.radius))
        disk = jnp.asarray(disk, dtype)
        success = jnp.asarray(self.task.success != REACH)
        zero = jnp.zeros((), dtype)
        state = EnvState(x=x, goal=goal, disk=disk, success=success, tracking_sum=zero, tracking_weight=zero, time=0)
        return self._observation(tuple(x), tuple(goal), tuple(disk), params), state

    def _observation(self, x: tuple, goal: tuple, disk: tuple, params: EnvParams, velocity=None) -> jax.Array:
        """The task's observation clipped to its bounds, float32; ``velocity`` the centre's (None: from the rolling
        constraint)."""
        trig = self._angles(x)
        if velocity is None:
            velocity = self._centre_velocity(x, trig, *disk)
        observation = jnp.stack(self._observe(x, trig, velocity, goal, tuple(params.settings)))
        high = jnp.asarray(params.observation_high, observation.dtype)
        return jnp.minimum(jnp.maximum(observation, -high), high).astype(jnp.float32)

    def step_env(
        self, key: jax.Array, state: EnvState, action: jax.Array, params: EnvParams
    ) -> tuple[jax.Array, EnvState, jax.Array, jax.Array, dict]:
        """One control period (the order of the engine's fused step)."""
        x, goal, settings = tuple(state.x), tuple(state.goal), tuple(params.settings)
        m, g, r = state.disk[0], state.disk[1], state.disk[2]
        action = jnp.clip(jnp.asarray(action, state.x.dtype), -1.0, 1.0)
        torques = [0.0, 0.0]
        for j, row in enumerate(params.actuators):
            torques[row] = params.max_torques[row] * action[j]
        effort = jnp.mean(action * action)
        tau_spin, tau_steer = torques
        dt = params.dt / params.substeps
        step = self._steps[params.integrator]
        new = x
        for _ in range(params.substeps):
            new = step(new, self._angles(new), dt, tau_spin, tau_steer, m, g, r)
        x, code = self._in_domain(x, new, engine.RUNNING)
        contact = self._contact(x, tau_spin, tau_steer, m, g, r)
        running = code == engine.RUNNING
        code = jnp.where(running, self._contact_status(contact[3], contact[4], params.friction_coefficient), code)
        trig = self._angles(x)
        velocity = self._centre_velocity(x, trig, m, g, r)
        if self._advance is not None:
            goal = goal[: len(self.task.goal_names)] + tuple(self._advance(x, trig, velocity, goal, settings))
        code = jnp.where(code == engine.RUNNING, self._termination(x, goal, settings), code)
        terms = self._reward_terms(x, trig, velocity, code, effort, goal, settings)
        reward = params.reward_weights[0] * terms[0]
        for weight, term in zip(params.reward_weights[1:], terms[1:]):
            reward = reward + weight * term
        success = code == (engine.REACHED if self.task.success == REACH else engine.RUNNING)
        tracking_sum, tracking_weight = state.tracking_sum, state.tracking_weight
        if self.task.success == TRACK:
            error = self._tracking_error(x, goal, settings)
            decay, bound = params.success_decay, params.success_bound
            tracking_sum, tracking_weight, within = self._track(tracking_sum, tracking_weight, error, decay, bound)
            success = success & within
        terminated = code != engine.RUNNING
        state = EnvState(
            x=jnp.stack(x),
            goal=jnp.stack(goal).astype(state.goal.dtype),
            disk=state.disk,
            success=success,
            tracking_sum=tracking_sum,
            tracking_weight=tracking_weight,
            time=state.time + 1,
        )
        observation = self._observation(x, goal, (m, g, r), params, velocity)
        info = {
            "state": state.x,
            "energy": contact[0],
            "contact_force": jnp.stack(contact[1:3]),
            "normal_force": contact[3],
            "required_friction": contact[4],
            "sliding": jnp.asarray(False),
            "slip_velocity": jnp.zeros(2, state.x.dtype),
            "is_success": success,
            "termination": code,
            **{name: state.disk[DRAWN.index(name)] for name in self.config.drawn_names},
            **dict(zip(self.term_keys, (jnp.asarray(term, state.x.dtype) for term in terms))),
        }
        observation, state = self._apply_transition_gradient_policy(observation, state)
        return observation, state, jnp.asarray(reward, state.x.dtype), terminated, info

    def is_terminated(self, state: EnvState, params: EnvParams) -> jax.Array:
        """Whether the state has fallen or reached the goal (the task's termination alone: the step also ends
        episodes that leave the model's domain or lift off)."""
        return self._termination(tuple(state.x), tuple(state.goal), tuple(params.settings)) != engine.RUNNING
