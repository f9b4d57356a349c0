"""RollingDisk-v0 for N disks with torch tensors in and out: on the GPU (the CUDA kernels) or over the CPU engine."""

from __future__ import annotations

import numpy as np
import torch
from gymnasium.vector import AutoresetMode

from rolling_disk_env.envs.batch import DiskBatch, Outputs
from rolling_disk_env.envs.vector import RollingDiskVectorEnv

DEVICES = ("cpu", "cuda")
"""The devices of :class:`RollingDiskTorchVectorEnv`."""


class RollingDiskTorchVectorEnv(RollingDiskVectorEnv):
    """:class:`~rolling_disk_env.envs.RollingDiskVectorEnv` with torch tensors in and out, what
    ``gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point", device=...)`` returns.

    The same arguments, spaces, autoreset modes, seeding and ``info`` keys, plus ``device``:

    - ``"cuda"``: the disks live in GPU memory and each step and reset is one launch of the task's CUDA kernel, a GPU
      thread a disk (:mod:`rolling_disk_env.gpu`; the ``[gpu]`` extra), on torch's current stream and the current
      CUDA device. Under numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``) the kernels run on the CPU and the
      tensors are CPU tensors.
    - ``"cpu"``: the CPU engine (:class:`~rolling_disk_env.envs.RollingDiskVectorEnv`'s batch, on numba's threads),
      its outputs handed out as tensors without a copy.

    ``step`` takes the actions as a torch tensor (or anything ``torch.as_tensor`` takes: DLPack, the CUDA array
    interface, numpy) of shape (N, A), converted to float32 on the env's device, clipped to [-1, 1]; non-finite
    actions raise ``ValueError`` as in the CPU env. It returns the observations (N, obs) float32, the rewards (N,)
    float32, terminated and truncated (N,) bool, and ``info`` as tensors on the device: ``"state"`` (N, 8) or (N, 10)
    float64, ``"energy"``, ``"contact_force"``, ``"normal_force"``, ``"required_friction"``, ``"sliding"``,
    ``"slip_velocity"``, ``"is_success"``, ``"termination"`` and the reward terms, each with its mask ``"_key"``. On
    the GPU the info tensors are views of buffers that the next step overwrites: clone what you keep. SAME_STEP's
    ``info["final_obs"]`` is a tensor (N, obs) whose rows hold the last observations where ``"_final_obs"`` is True.
    ``reset(options=...)`` takes ``"reset_mask"`` and ``"state"`` as tensors or arrays.

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
        super().__init__(num_envs, max_episode_steps, render_mode, autoreset_mode, **kwargs)
        if self._on_gpu:
            self.device = self._batch.device
            self._rngs = self._batch.rngs
            self._ended = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)

    def _new_batch(self, max_episode_steps: int | None) -> DiskBatch:
        if not self._on_gpu:
            return super()._new_batch(max_episode_steps)
        from rolling_disk_env.gpu import DeviceBatch

        return DeviceBatch(self.config, self.num_envs, max_episode_steps)

    def _set_rngs(self, words: np.ndarray, mask: np.ndarray) -> None:
        if self._on_gpu:
            rows = np.flatnonzero(mask).tolist()
            self._batch.seed(rows, words[rows])
        else:
            super()._set_rngs(words, mask)

    def _like_ended(self, mask: np.ndarray):
        return self._tensor(mask) if self._on_gpu else mask

    def _tensor(self, array) -> torch.Tensor:
        """``array`` as a tensor on the env's device: a numpy array without a copy on the CPU."""
        return array if isinstance(array, torch.Tensor) else torch.as_tensor(array, device=self.device)

    @staticmethod
    def _kept(array):
        return array.clone() if isinstance(array, torch.Tensor) else array.copy()

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
        for key in ("reset_mask", "state"):
            if isinstance(options.get(key), torch.Tensor):
                options[key] = options[key].detach().cpu().numpy()
        observations, infos = super().reset(seed=seed, options=options)
        return self._observations(observations), infos

    def step(self, actions):
        observations, rewards, terminated, truncated, infos = super().step(actions)
        return (
            self._observations(observations),
            self._tensor(rewards).float(),
            self._tensor(terminated),
            self._tensor(truncated),
            infos,
        )

    def _observations(self, observations) -> torch.Tensor:
        """The observations handed out: the GPU's buffer copied (the next step writes it), the CPU's fresh array
        as it is."""
        return observations.clone() if self._on_gpu else torch.from_numpy(observations)

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
