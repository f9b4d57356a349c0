"""Rendering: frames of the right shape in which the disk is visible, headless, and a recorded video."""

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.rendering import DISK


def _disk_pixels(frame: np.ndarray) -> int:
    return int(np.sum(np.all(frame == DISK, axis=-1)))


@pytest.mark.parametrize("task", ["upright", "circle"])
def test_rgb_array_frames_show_the_disk(task):
    env = gym.make(rd.ENV_ID, task=task, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (400, 600, 3) and frame.dtype == np.uint8
    assert _disk_pixels(frame) > 1500
    env.step(env.action_space.sample())
    assert not np.array_equal(env.render(), frame)
    env.close()


def test_rgb_array_mode_opens_no_display():
    import pygame

    env = gym.make(rd.ENV_ID, render_mode="rgb_array")
    env.reset(seed=0)
    env.render()
    assert not pygame.display.get_init()


def test_the_drawing_follows_the_state():
    # The circle task's camera looks at the circle's centre along +y: a disk moved from x = -3 m to x = +3 m (facing
    # the camera, psi = pi/2) moves to the right of the picture.
    env = gym.make(rd.ENV_ID, task="circle", render_mode="rgb_array")
    columns = []
    for c1 in (-3.0, 3.0):
        env.reset(seed=0, options={"state": [c1, 0, 0, 0.0, np.pi / 2, 2, 0, 0]})
        mask = np.all(env.render() == DISK, axis=-1)
        assert mask.sum() > 500
        columns.append(np.nonzero(mask)[1].mean())
    assert columns[1] - columns[0] > 100


def test_human_mode_runs_headless():
    env = gym.make(rd.ENV_ID, render_mode="human")
    env.reset(seed=0)
    for _ in range(3):
        env.step(env.action_space.sample())
    env.close()


def test_record_video_writes_a_file(tmp_path):
    folder = tmp_path / "videos"
    env = gym.make(rd.ENV_ID, render_mode="rgb_array", max_episode_steps=30)
    env = gym.wrappers.RecordVideo(env, str(folder), episode_trigger=lambda episode: True, disable_logger=True)
    env.reset(seed=0)
    truncated = terminated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
    env.close()
    videos = list(folder.glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 1000
