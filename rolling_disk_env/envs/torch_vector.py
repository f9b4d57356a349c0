"""RollingDisk-v0 for N disks with torch tensors in and out: on the GPU (the CUDA kernels) or over the CPU engine."""

from __future__ import annotations

import functools

import gymnasium as gym
import numpy as np
import torch
from gymnasium.vector import AutoresetMode

from rolling_disk_env import engine, pcg64
from rolling_disk_env.envs.batch import DiskBatch, Outputs
from rolling_disk_env.envs.vector import RollingDiskVectorEnv

DEVICES = ("cpu", "cuda")
"""The devices of :class:`RollingDiskTorchVectorEnv`."""
MODES = {
    AutoresetMode.NEXT_STEP: engine.NEXT_STEP,
    AutoresetMode.SAME_STEP: engine.SAME_STEP,
    AutoresetMode.DISABLED: engine.DISABLED,
}
"""The autoreset modes as the device's kernels take them."""


class RollingDiskTorchVectorEnv(RollingDiskVectorEnv):
    """:class:`~rolling_disk_env.envs.RollingDiskVectorEnv` with torch tensors in and out, what
    ``gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point", device=...)`` returns.

    The same arguments, spaces, autoreset modes and seeding, plus ``device``:

    - ``"cuda"``: the disks live in GPU memory and each step and reset is one launch of the task's CUDA kernel, a GPU
      thread a disk (:mod:`rolling_disk_env.gpu`; the ``[gpu]`` extra), on torch's current stream and the current
      CUDA device. Under numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``) the kernels run on the CPU and the
      tensors are CPU tensors.
    - ``"cpu"``: the CPU engine (:class:`~rolling_disk_env.envs.RollingDiskVectorEnv`'s batch, on numba's threads),
      its outputs handed out as tensors without a copy.

    ``info_keys`` is ``"training"`` by default here: ``info`` holds ``"is_success"`` and ``"termination"`` (and the
    drawn constants of ``params_ranges``), what trainers and autoreset read, and the step writes nothing else;
    ``info_keys="full"`` gives the numpy env's keys (and writes them).

    ``step`` takes the actions as a torch tensor (or anything ``torch.as_tensor`` takes: DLPack, the CUDA array
    interface, numpy) of shape (N, A), converted to float32 on the env's device, clipped to [-1, 1]. It returns the
    observations (N, obs) float32, the rewards (N,) float32, terminated and truncated (N,) bool, and ``info`` as
    tensors on the device, each key with its mask ``"_key"``; with ``info_keys="full"``: ``"state"`` (N, 8) or (N,
    10) float64, ``"energy"``, ``"contact_force"``, ``"normal_force"``, ``"required_friction"``, ``"sliding"``,
    ``"slip_velocity"``, ``"is_success"``, ``"termination"`` and the reward terms. On the GPU the info tensors are
    views of buffers that the next step overwrites: clone what you keep. SAME_STEP's ``info["final_obs"]`` is a tensor
    (N, obs) whose rows hold the last observations where ``"_final_obs"`` is True; its ``"final_info"`` has the keys
    of ``info_keys``. ``reset(options=...)`` takes ``"reset_mask"`` and ``"state"`` as tensors or arrays.

    On the CPU, non-finite actions raise ``ValueError`` at the step, as in the numpy env. On the GPU a step never
    waits for the device: it queues its launches and an asynchronous copy of the check's status word, and copies
    nothing else between host and device (:class:`~rolling_disk_env.gpu.DeviceBatch`). A step whose actions hold a
    non-finite value (or, under DISABLED, an ended disk) steps no disk, nor does any step after it, and the first
    ``step()`` or ``reset()`` after the device has done it raises ``ValueError``
    (:class:`~rolling_disk_env.gpu.DeviceStepError`) naming the step and the disks: the outputs of the steps in
    between are meaningless. ``reset(options={"reset_mask": mask})`` with a mask on the device copies nothing
    either, and so does not check that the mask holds a True (an empty mask resets no disk). The one difference from
    ``SyncVectorEnv`` there: under SAME_STEP, ``"final_obs"`` and ``"final_info"`` (views too) are in the info of every
    step, their masks False where no episode ended (a host check of the flags would cost a synchronization a step).

    ``reset(seed=s)`` draws the same episodes as the CPU vector env (the same PCG64 streams,
    :mod:`rolling_disk_env.pcg64`), and the steps follow it within the rounding of fused multiply-adds on the GPU
    (``tests/test_gpu.py``).
    """

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        render_mode: None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        device: str | torch.device = "cpu",
        info_keys: str = "training",
        **kwargs,
    ):
        try:
            requested = torch.device(device)
        except (RuntimeError, TypeError):
            requested = None
        if requested is None or requested.type not in DEVICES:
            raise ValueError(f"device must be one of {list(DEVICES)} (or a torch.device of them), got {device!r}")
        if requested.type == "cuda" and requested.index not in (None, _current_cuda_index()):
            raise ValueError(
                f"device={device!r}: the env runs on the current CUDA device ({_current_cuda_index()}); "
                "select another with torch.cuda.set_device() before making the env"
            )
        self._on_gpu = requested.type == "cuda"
        self.device = torch.device("cpu")
        super().__init__(num_envs, max_episode_steps, render_mode, autoreset_mode, info_keys, **kwargs)
        if self._on_gpu:
            self.device = self._batch.device
            self._rngs = self._batch.rngs
            self._ended = self._batch.ended
            self._all = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
            self._step_infos, self._refresh = self._device_infos(self._batch.out, self._batch.disk_tensor, self._all)
            if self.autoreset_mode == AutoresetMode.SAME_STEP:
                batch = self._batch
                final_info, refresh = self._device_infos(batch.final, batch.final_disk, batch.final_mask)
                self._step_infos.update(
                    final_obs=batch.final.observations,
                    _final_obs=batch.final_mask,
                    final_info=final_info,
                    _final_info=batch.final_mask,
                )
                self._refresh += refresh

    def _new_batch(self, max_episode_steps: int | None) -> DiskBatch:
        if not self._on_gpu:
            return super()._new_batch(max_episode_steps)
        from rolling_disk_env.gpu import DeviceBatch

        return DeviceBatch(self.config, self.num_envs, max_episode_steps, MODES[self.autoreset_mode], self.info_keys)

    def _set_rngs(self, words: np.ndarray, mask: np.ndarray) -> None:
        if self._on_gpu:
            self._batch.seed(words, mask)
        else:
            super()._set_rngs(words, mask)

    @property
    def steps(self) -> torch.Tensor:
        """(N,) int64: each disk's steps in its current episode (it truncates at ``max_episode_steps``), a view of the
        batch's counters (no copy); assigning to it (e.g. random counts, so that the disks do not all truncate at the
        same step) moves the disks within their episodes."""
        if self._on_gpu:
            return self._batch.steps_tensor
        return torch.from_numpy(self._batch.steps[: self.num_envs])

    @steps.setter
    def steps(self, counts) -> None:
        self.steps.copy_(torch.as_tensor(counts).view(-1))

    def _tensor(self, array) -> torch.Tensor:
        """``array`` as a tensor on the env's device: a numpy array without a copy on the CPU."""
        return array if isinstance(array, torch.Tensor) else torch.as_tensor(array, device=self.device)

    def _checked_actions(self, actions):
        """The actions as a C-contiguous float32 tensor on the device, clipped to [-1, 1] (the batch checks that they
        are finite); on the CPU, as the CPU batch takes them (a numpy view)."""
        if isinstance(actions, torch.Tensor):
            actions = actions.detach()
        else:
            try:
                actions = torch.as_tensor(actions)
            except (TypeError, ValueError, RuntimeError) as error:
                raise ValueError(
                    f"actions must be a tensor or array of numbers, got {type(actions).__name__}"
                ) from error
        if tuple(actions.shape) != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {tuple(actions.shape)}")
        if actions.dtype == torch.bool or actions.is_complex():
            raise ValueError(f"actions must be finite numbers (ints or floats), got a {actions.dtype} tensor")
        if actions.dtype != torch.float32:  # finite values clipped before the cast, which would make large ones inf
            actions = actions.double()
            actions = torch.where(torch.isfinite(actions), actions.clamp(-1.0, 1.0), actions)
        actions = actions.to(self.device, torch.float32).contiguous()
        return actions if self._on_gpu else actions.numpy()

    def reset(self, *, seed=None, options: dict | None = None):
        options = dict(options or {})
        if self._on_gpu:
            return self._reset_on_device(seed, options)
        for key in ("reset_mask", "state"):
            if isinstance(options.get(key), torch.Tensor):
                options[key] = options[key].detach().cpu().numpy()
        observations, infos = super().reset(seed=seed, options=options)
        return self._observations(observations), infos

    def _reset_on_device(self, seed, options: dict):
        """:meth:`reset` on the GPU: a device mask stays there."""
        mask = options.pop("reset_mask", None)
        if mask is not None:
            mask = self._device_mask(mask)
        if isinstance(options.get("state"), torch.Tensor):
            options["state"] = options["state"].detach().cpu().numpy()
        states = self.config.reset_state(options, self.num_envs)
        on_device = isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and 0 <= seed
        on_device = on_device and int(seed) + self.num_envs <= pcg64.SEED_LIMIT
        if not on_device and (seed is not None or not self._seeded):  # a list, fresh entropy, a large seed: the host's
            self._seed(seed, np.ones(self.num_envs, bool) if mask is None else mask.cpu().numpy())
        self._seeded = self._seeded or on_device
        self._batch.reset(mask, states, int(seed) if on_device else None)
        self._last = self._batch.out
        infos, refresh = self._device_infos(
            self._batch.out, self._batch.disk_tensor, self._all if mask is None else mask.clone()
        )
        for update in refresh:
            update()
        return self._batch.out.observations.clone(), infos

    def _device_mask(self, mask) -> torch.Tensor:
        """``options["reset_mask"]`` checked as ``SyncVectorEnv`` checks it (but for a True in a mask on the device,
        which would read it), on the device."""
        if isinstance(mask, torch.Tensor):
            if self._last is None:
                raise ValueError('options["reset_mask"] resets some sub-environments: reset all of them first')
            if tuple(mask.shape) != (self.num_envs,) or mask.dtype != torch.bool:
                raise ValueError(
                    f'options["reset_mask"] must be a bool tensor or array of shape ({self.num_envs},), got a '
                    f"{mask.dtype} tensor of shape {tuple(mask.shape)}"
                )
            return mask.detach().to(self.device)
        return torch.from_numpy(self._reset_mask(mask)).to(self.device)

    def step(self, actions):
        if self._on_gpu:
            return self._step_on_device(actions)
        observations, rewards, terminated, truncated, infos = super().step(actions)
        return (
            self._observations(observations),
            self._tensor(rewards).float(),
            self._tensor(terminated),
            self._tensor(truncated),
            infos,
        )

    def _step_on_device(self, actions):
        """:meth:`step` on the GPU: nothing waits for the device (the batch's
        :meth:`~rolling_disk_env.gpu.DeviceBatch.step` raises an earlier step's error once the device has done it)."""
        if self._last is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        observations, rewards, terminated, truncated = self._batch.step(self._checked_actions(actions))
        for update in self._refresh:
            update()
        return observations, rewards, terminated, truncated, dict(self._step_infos)

    def _device_infos(self, out: Outputs, disks: torch.Tensor, mask: torch.Tensor) -> tuple[dict, list]:
        """The batched info of ``out`` (the GPU batch's, with the disks' constants ``disks``, (m, g, r, mu) rows) with
        the mask ``mask``: views of its tensors, made once, and
        the updates that refresh the values that are not views (under the ``"sliding"`` and ``"coulomb"``
        contacts, the 10-state and the sliding flags) after each step."""
        info, first, n, refresh = out.info, self._batch.contact_rows, self.num_envs, []
        if self.info_keys == "training":
            return self._masked_infos(out, None, None, None, disks, mask), refresh
        if first is None:
            state, sliding = info[:8].T, torch.zeros(n, dtype=torch.bool, device=self.device)
            slip = torch.zeros((n, 2), dtype=torch.float64, device=self.device)
        else:
            rows = torch.as_tensor(self._batch.state_rows, device=self.device)
            states = torch.empty((len(rows), n), dtype=torch.float64, device=self.device)
            sliding = torch.empty(n, dtype=torch.bool, device=self.device)
            refresh += [
                functools.partial(torch.index_select, info, 0, rows, out=states),
                functools.partial(torch.gt, info[first + 4], 0.0, out=sliding),
            ]
            state, slip = states.T, info[first + 2 : first + 4].T
        return self._masked_infos(out, state, sliding, slip, disks, mask), refresh

    @staticmethod
    def _observations(observations: np.ndarray) -> torch.Tensor:
        """The CPU's fresh observations as a tensor, without a copy."""
        return torch.from_numpy(observations)

    def _infos(self, out: Outputs, present) -> dict:
        infos, tensors = super()._infos(out, present), {}
        for key, value in infos.items():  # each array once: the masks are one array
            if id(value) not in tensors:
                tensors[id(value)] = self._tensor(value)
            infos[key] = tensors[id(value)]
        return infos

    def _final(self, out: Outputs, ended) -> dict:
        kept = Outputs(self.num_envs, tuple(self._kept(array) for array in out.shares))
        ended = self._tensor(ended)
        return {
            "final_obs": self._tensor(kept.observations),
            "_final_obs": ended,
            "final_info": self._infos(kept, ended),
            "_final_info": ended.clone(),
        }


def _current_cuda_index() -> int | None:
    """The current CUDA device's index, or None where torch sees none."""
    return torch.cuda.current_device() if torch.cuda.is_available() else None
