"""RollingDisk-v0: one disk, stepped by the compiled engine (a batch of one: the vector env's kernels)."""

from __future__ import annotations

from collections import deque
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from rolling_disk_env import engine
from rolling_disk_env.dynamics import DiskParams
from rolling_disk_env.envs.batch import DiskBatch
from rolling_disk_env.envs.config import EnvConfig, checked_actions

TRACK_LENGTH = 5000
"""Points of the centre's track kept for rendering."""
MAX_RENDER_FPS = 1000
"""Frames per second a display is asked for at most (``metadata["render_fps"]`` is ``1 / dt`` within [1, this])."""


class RollingDiskEnv(gym.Env[np.ndarray, np.ndarray]):
    """A thin disk rolling without slipping on a plane, driven by a spin and a steer torque.

    ## Description

    The disk of L. Jaulin's *Modelisation of a rolling disk with Sympy*: state
    ``x = (c1, c2, phi, theta, psi, dphi, dtheta, dpsi)`` (centre position in m; spin, lean and heading in rad; their
    rates in rad/s), exact rolling-without-slipping dynamics derived with SymPy, no energy loss. Two optional
    actuators apply physical torques to the disk: ``spin`` about its symmetry axis and ``steer`` about the vertical.
    The lean theta has no actuator of its own: torques reach it through gyroscopic coupling.

    ## Action Space

    ``Box(-1, 1, (n,), float32)``, one component per actuator in the order ``("spin", "steer")`` (those enabled),
    scaled to ``max_spin_torque`` and ``max_steer_torque`` (N m). Finite actions outside [-1, 1] are clipped (any
    finite number, 1e300 too); NaN, inf, a wrong shape or values that are not ints or floats (bools, complex
    numbers, strings) raise ``ValueError``. With ``actuators=()`` the space is empty and the disk is passive.

    ## Observation Space

    ``Box(float32)`` holding only what the task needs, relative to its target, clipped to its bounds (rates to
    +-100 rad/s). ``task="upright"``:

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 0 | lean theta (rad) | -pi/2 | pi/2 |
    | 1 | lean rate dtheta (rad/s) | -100 | 100 |
    | 2 | spin-rate error dphi - dphi* (rad/s) | -100 | 100 |
    | 3 | heading rate dpsi (rad/s) | -100 | 100 |

    ``task="circle"``:

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 0 | radial error of the centre, \\|c - centre\\| - R (m) | -10 | 10 |
    | 1 | sin of the heading error to the circle's tangent | -1 | 1 |
    | 2 | cos of the heading error | -1 | 1 |
    | 3 | lean error theta - theta* (rad) | -pi | pi |
    | 4 | lean rate dtheta (rad/s) | -100 | 100 |
    | 5 | spin-rate error dphi - dphi* (rad/s) | -100 | 100 |
    | 6 | heading-rate error dpsi - dpsi* (rad/s) | -100 | 100 |
    | 7 | target lean theta* of the episode's circle (rad) | -pi/2 | pi/2 |

    ``task="goto"`` (beta: the target's bearing from the rolling direction ``(sin psi, -cos psi)``, positive to the
    left):

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 0 | horizontal distance d from the centre to the target (m) | -20 | 20 |
    | 1 | sin beta | -1 | 1 |
    | 2 | cos beta | -1 | 1 |
    | 3 | lean theta (rad) | -pi/2 | pi/2 |
    | 4 | lean rate dtheta (rad/s) | -100 | 100 |
    | 5 | spin-rate error dphi - dphi* to the cruise speed, dphi* = 2 m/s / r (rad/s) | -100 | 100 |
    | 6 | heading rate dpsi (rad/s) | -100 | 100 |

    ``task="waypoints"`` (bearings as ``goto``'s):

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 0 | distance to the next waypoint (m) | -15 | 15 |
    | 1 | sin of its bearing | -1 | 1 |
    | 2 | cos of its bearing | -1 | 1 |
    | 3 | distance to the waypoint after it (the next one's again for the last) (m) | -15 | 15 |
    | 4 | sin of its bearing | -1 | 1 |
    | 5 | cos of its bearing | -1 | 1 |
    | 6 | lean theta (rad) | -pi/2 | pi/2 |
    | 7 | lean rate dtheta (rad/s) | -100 | 100 |
    | 8 | spin-rate error dphi - dphi* to the cruise speed, dphi* = 2 m/s / r (rad/s) | -100 | 100 |
    | 9 | heading rate dpsi (rad/s) | -100 | 100 |
    | 10 | the fraction of the four waypoints still ahead | -1 | 1 |

    ``task="eight"`` (against the lobe of the next gate, s = +1 counter-clockwise, -1 clockwise):

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 0 | radial error to the lobe's circle (m) | -10 | 10 |
    | 1 | sin of the heading error to the lobe's direction of travel | -1 | 1 |
    | 2 | cos of the heading error | -1 | 1 |
    | 3 | lean error theta - s theta* (rad) | -pi | pi |
    | 4 | lean rate dtheta (rad/s) | -100 | 100 |
    | 5 | spin-rate error dphi - dphi* (rad/s) | -100 | 100 |
    | 6 | heading-rate error dpsi - s dpsi* (rad/s) | -100 | 100 |
    | 7 | target lean s theta* of the steady circle (rad) | -pi/2 | pi/2 |
    | 8 | sin of the turn left to the next gate | -1 | 1 |
    | 9 | cos of the turn left to the next gate | -1 | 1 |
    | 10 | the lobe's gates left after the next, over 3 | -1 | 1 |

    ``task="recovery"`` and ``task="recovery_sparse"``:

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 0 | lean theta (rad) | -pi/2 | pi/2 |
    | 1 | lean rate dtheta (rad/s) | -100 | 100 |
    | 2 | spin-rate error dphi - dphi* to the target speed, dphi* = 2 m/s / r (rad/s) | -100 | 100 |
    | 3 | heading rate dpsi (rad/s) | -100 | 100 |
    | 4 | the fraction of the hold (1 s) the disk has been upright | -1 | 1 |

    ``task="ice"``: ``goto``'s 7, then:

    | Num | Observation | Min | Max |
    |-----|-------------|-----|-----|
    | 7 | slip velocity of the contact point along the rolling direction (m/s) | -10 | 10 |
    | 8 | slip velocity to its left (m/s) | -10 | 10 |

    ## Rewards

    A weighted sum of named terms, each in [-1, 1] per step, reported flat in ``info["reward_<term>"]`` (as
    Gymnasium's MuJoCo envs report ``reward_ctrl``), so that batching wrappers stack them; the weights are the task
    option ``reward_weights``. ``upright``: ``alive`` +1, ``lean`` -min((theta / 0.5)^2, 1), ``speed``
    -min(((dphi - dphi*) / dphi*)^2, 1), ``effort`` -mean(action^2); weights 1, 1, 0.5, 0.1. ``circle``: ``alive``
    +1, ``radial`` -min(e_r^2, 1) (e_r in m), ``speed`` as above, ``effort``; weights 1, 1, 0.3, 0.1. ``goto``:
    ``progress`` the centre's velocity towards the target over the cruise speed (clipped), ``aim``
    -min(miss^2, 1) (miss: how far in m the disk would pass from the target rolling straight on), ``speed`` as above
    (to the cruise speed), ``upright`` -min((theta / 0.8)^2, 1), ``effort``, ``reached`` +1 on the step the target
    is reached, ``fallen`` -1 on the step the disk falls or lifts off; weights 1, 0.2, 0.3, 0.5, 0.1, 100, 100.
    ``waypoints``: ``goto``'s towards the next waypoint, and ``waypoint`` +1 on the step one is passed; weights 1,
    0.2, 0.3, 0.5, 0.1, 20, 100, 100. ``eight``: ``progress`` along the lobe's direction of travel over the target
    speed, ``radial``, ``speed``, ``effort``, ``gate`` +1 on the step a gate counts, ``reached``, ``fallen`` (a
    fall, a lift-off or straying off the course); weights 1, 1, 0.3, 0.1, 10, 100, 100. ``recovery``: ``upright``
    -min((theta / 1.4)^2, 1), ``rates`` -min((dtheta^2 + dpsi^2) / 4, 1), ``speed``, ``effort``, ``recovered`` +1 on
    success, ``fallen``; weights 1, 0.2, 0.3, 0.1, 100, 100; ``recovery_sparse``: the same terms, weights 0 but
    ``recovered`` 1. ``ice``: ``goto``'s and ``grip`` -min((|slip| / 0.1 m/s)^2, 1), weight 0.5.

    ## Starting State

    ``upright``: at the origin, lean and rates drawn from ``initial_ranges`` (default theta in [-0.05, 0.05] rad,
    dtheta and dpsi in [-0.1, 0.1] rad/s, dphi in [0.8, 1.2] rad/s: slower than the self-stabilizing
    sqrt(g / 3r) = 1.81 rad/s, so a passive disk falls); phi and psi uniform. ``circle``: near a circle of radius R
    drawn from [3, 6] m, tangent to it, vertical and rolling straight at the target speed (2 m/s). ``goto``: as
    ``upright``, with a target 3 to 8 m away at any bearing from the initial rolling direction. ``waypoints``: as
    ``goto``, four waypoints each 3 to 6 m from the one before. ``eight``: on the figure eight of two circles of
    radius 2.5 to 3.5 m, at a gate, upright and rolling straight at 2.5 m/s. ``recovery``: on a steady circle at a
    lean of 0.8 to 1.25 rad either side, turning at 2.5 to 4 rad/s, perturbed. ``ice``: as ``goto``. The task
    modules document every range. ``reset(options={"state": x0})`` starts from an exact state instead (8 numbers, or
    under the ``"sliding"`` and ``"coulomb"`` contacts 8 (rolling) or 10).

    ## Episode End

    Termination, with the reason in ``info["termination"]``, a code of ``rolling_disk_env.Termination`` (an int;
    ``Termination.NONE``, 0, at every step that does not terminate, truncated ones included):

    | reason | when |
    |--------|------|
    | `FALLEN` | \\|theta\\| > ``fall_lean`` (0.5 rad for ``upright``, 1.4 for ``recovery``, 0.8 for the others) |
    | `REACHED` | the task's goal (a success): the target, the last waypoint, a whole eight, upright rolling held |
    | `OFF_COURSE` | ``eight``: more than 1 m from the next gate's circle |
    | `LIFTED_OFF` | the normal force N vanished: rolling on the plane is over (checked at every step) |
    | `SLIPPED` | ``"rolling"`` contact, ``friction_coefficient`` mu set: it needs more, \\|lambda\\| / N > mu |
    | `OUT_OF_DOMAIN` | a fixed-step integrator left the model's domain \\|theta\\| < pi/2 - 0.01 (use ``"dopri5"``) |
    | `SUBSTEP_LIMIT` | ``"dopri5"`` did not finish the period in 10000 steps |

    ``OUT_OF_DOMAIN`` also ends a ``contact="sliding"`` episode with mu > 0 where the slip stops and friction could
    hold the disk: the kinetic law has no force there (``"coulomb"`` rolls on). The contact is checked at the end of
    each control period. Truncation: after ``max_episode_steps`` (500 steps of
    0.02 s, 10 s), by the ``TimeLimit`` wrapper of ``gymnasium.make``.

    ``info`` holds the same keys at every step and at reset, each a number or an array of numbers, as Gymnasium's
    MuJoCo envs give them (so that Tianshou's buffers and TorchRL's info reader stack them): ``"state"`` (the
    8-vector, float64; the 10-vector ``rolling_disk_env.SLIDING_STATE_NAMES`` under the ``"sliding"`` and
    ``"coulomb"`` contacts), ``"energy"`` (J), ``"contact_force"`` (lambda1, lambda2: the horizontal ground reaction
    in N), ``"normal_force"`` (N, the vertical one), ``"required_friction"`` (|lambda| / N, the friction coefficient
    a real contact needs to roll so; mu while sliding), ``"sliding"`` (bool, False under ``"rolling"``),
    ``"slip_velocity"`` (m/s, the contact point's horizontal velocity; zeros while rolling), the
    ``"reward_<term>"`` keys (0 at reset), ``"termination"`` and
    ``"is_success"``: whether the episode counts as a success *if it ended at this step*, so True from the first
    step for a disk that has not fallen (``upright``: not fallen; ``circle``: not fallen and an exponentially weighted
    mean radial error, time constant 2.5 s, of at most 0.25 m), while on ``goto`` it is False until the step that
    reaches the target. SB3's ``Monitor`` and ``EvalCallback`` read it at the end.

    ## Arguments

    ```python
    import gymnasium as gym
    import rolling_disk_env

    env = gym.make("RollingDisk-v0", task="circle", render_mode="rgb_array")
    ```

    | Parameter | Type | Default | Description |
    |-----------|------|---------|-------------|
    | `task` | str or Task | `"upright"` | a key of ``rolling_disk_env.TASK_IDS`` (or a `Task` instance) |
    | `actuators` | tuple of str | `("spin", "steer")` | enabled torques; `()` gives a passive disk |
    | `dt` | float | `0.02` | control period, s (also `1 / render_fps`) |
    | `integrator` | str | `"rk4"` | `"euler"`, `"symplectic_euler"`, `"rk4"` or `"dopri5"` (error-controlled) |
    | `substeps` | int | `1` | fixed-step integrator steps per control period |
    | `rtol`, `atol` | float | `1e-6`, `1e-8` | tolerances of `"dopri5"` (relative, absolute) |
    | `friction_coefficient` | float | `None` | mu of the contact (`"rolling"`: the episode ends `SLIPPED` past it) |
    | `contact` | str | the task's | `"rolling"`, `"sliding"` (kinetic friction mu; 0: ice) or `"coulomb"` (``ice``'s) |
    | `max_spin_torque` | float | `5.0` | torque of action +1 on spin, N m |
    | `max_steer_torque` | float | `10.0` | torque of action +1 on steer, N m |
    | `params` | DiskParams | `DiskParams()` | mass 5 kg, radius 1 m, gravity 9.81 m/s^2 |
    | `params_ranges` | dict | `None` | per-episode ranges of mass, gravity, radius, friction_coefficient (see below) |
    | `initial_ranges` | dict | `None` | overrides of the task's initial-state ranges (keys per task) |
    | `task_options` | dict | `None` | the task's arguments (`target_speed`, `reward_weights`, `fall_lean`, ...) |
    | `render_mode` | str | `None` | `"human"` or `"rgb_array"` |

    ``params_ranges`` draws each episode's disk uniformly from ``(low, high)`` ranges, keyed ``"mass"`` (kg),
    ``"gravity"`` (m/s^2), ``"radius"`` (m) and, under the ``"sliding"`` and ``"coulomb"`` contacts,
    ``"friction_coefficient"`` (in [0, sqrt(5)/2)); a bad key or range raises ``ValueError`` naming it. The drawn values
    are in ``info`` under those keys, at the reset and at every step of the episode (in ``final_info`` too).

    ## Version History

    * v0: initial version; the compiled engine (numba) computes the same transitions as before to within the
      rounding of its sine and cosine; flat ``reward_<term>`` info keys, the contact limits and ``"dopri5"`` added;
      every info key at every step, ``info["termination"]`` a ``Termination`` code (it was a name, on terminal steps
      only); ``contact=`` (``"sliding"``, ``"coulomb"``) with ``info["sliding"]`` and ``info["slip_velocity"]``; the
      tasks ``waypoints``, ``eight``, ``recovery``, ``recovery_sparse`` and ``ice``, ``Termination.OFF_COURSE``, the
      friction coefficient in ``params_ranges`` and the drawn constants in ``info``.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "render_fps": 50}

    def __init__(self, render_mode: str | None = None, **kwargs):
        self.config = EnvConfig.from_kwargs(**kwargs)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.render_mode = render_mode
        fps = min(MAX_RENDER_FPS, max(1, round(1 / self.config.dt)))
        self.metadata = {**self.metadata, "render_fps": fps}
        self.task = self.config.task
        self.dt = self.config.dt
        self.action_space = self.config.action_space
        self.observation_space = self.config.observation_space
        self._batch = DiskBatch(self.config, 1, None)
        self._out = self._batch.outputs()
        self._column = self._out.info[:, 0]  # the disk's column of the info block: a view, made once (0.3 us)
        self._reset_mask = np.ones(1, dtype=bool)
        self._term_keys = [f"reward_{name}" for name in self.task.reward_weights]
        self._renderer = None
        self._track = None
        self.params: DiskParams | None = None
        self._started = False

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        state = self.config.reset_state(options)
        batch = self._batch
        batch.uniforms[0] = self.np_random.random(self.config.draws)
        batch.reset(self._reset_mask, self._out, states=None if state is None else state[None])
        self._started = True
        m, g, r = batch.disks[:, 0].tolist()
        self.params = DiskParams(mass=m, radius=r, gravity=g) if self.config.params_ranges else self.config.params
        self._track = None if self.render_mode is None else deque([tuple(batch.states[:2, 0])], TRACK_LENGTH)
        if self.render_mode == "human":
            self.render()
        return self._out.observations[0].copy(), self._info(False)[0]

    def step(self, action):
        if not self._started:
            raise gym.error.ResetNeeded("call reset() before step()")
        actions = self._actions(action)
        out = self._out
        if self._batch.step(actions, out) >= 0:
            raise ValueError(f"action must be finite numbers, got {action!r}")
        terminated = out.flags.item(engine.TERMINATED, 0)
        info, reward = self._info(terminated)
        if self._track is not None:
            self._track.append(tuple(self._batch.states[:2, 0]))
        if self.render_mode == "human":
            self.render()
        return out.observations[0].copy(), reward, terminated, False, info

    def _actions(self, action) -> np.ndarray:
        """The action as the engine takes it, a row of float32 (finiteness is checked by the engine)."""
        if (
            type(action) is np.ndarray
            and action.dtype == np.float32
            and action.shape == self.action_space.shape
            and action.flags.c_contiguous
        ):
            return action.reshape(1, -1)
        return checked_actions(action, self.action_space.shape).reshape(1, -1)

    def _info(self, terminated: bool) -> tuple[dict, float]:
        """The info, from a copy of the disk's column of the info block (its arrays are views of that copy), with the
        same keys at every step and reset; and the reward."""
        column = self._column.copy()
        values = column.tolist()
        first = self._batch.contact_rows
        info = {
            "state": column[self._batch.state_rows],
            "energy": values[engine.ENERGY],
            "contact_force": column[engine.LAMBDA1 : engine.LAMBDA2 + 1],
            "normal_force": values[engine.NORMAL_FORCE],
            "required_friction": values[engine.REQUIRED_FRICTION],
            "sliding": first is not None and values[first + 4] > 0.0,
            "slip_velocity": np.zeros(2) if first is None else column[first + 2 : first + 4],
            "is_success": self._out.flags.item(engine.SUCCESS, 0),
            "termination": self._out.codes.item(0) if terminated else engine.RUNNING,
        }
        info.update(zip(self._term_keys, values[engine.TERMS :]))
        for name, row in self._batch.drawn_rows:
            info[name] = self._batch.lanes.item(row, 0)
        return info, values[engine.REWARD]

    @property
    def goal(self) -> dict[str, float]:
        """The episode's goal: its targets (the task's ``goal_names``) and its progress so far (``progress_names``),
        by name; empty before the first reset."""
        if not self._started:
            return {}
        return dict(zip((*self.task.goal_names, *self.task.progress_names), self._batch.goals[:, 0].tolist()))

    def render(self):
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or 'human' to gymnasium.make"
            )
            return None
        if self._renderer is None:
            from rolling_disk_env.rendering import DiskRenderer

            self._renderer = DiskRenderer(self.render_mode, self.metadata["render_fps"])
        time = self._batch.steps[0] * self.dt
        state = self._batch.states[:, 0].tolist()
        return self._renderer.draw(time, state, self.params, self.goal, self.task, self._track)

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self) -> dict:
        """Pickles without the renderer (a pygame surface), which the next ``render()`` rebuilds, and without the view
        of the info block (which would pickle as a copy)."""
        state = {**self.__dict__, "_renderer": None}
        del state["_column"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._column = self._out.info[:, 0]
