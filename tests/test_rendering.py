"""Rendering: frames of the right shape in which the disk is visible, a camera that keeps it in view, a legend,
headless, and a recorded video."""

import gymnasium as gym
import numpy as np
import pytest

import rolling_disk_env as rd
from rolling_disk_env.rendering import DISK, LEGEND_BACKGROUND, RIM, TARGET


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


def test_the_camera_keeps_a_passive_disk_in_view_as_it_leaves_the_circle():
    # A passive disk rolls straight off the target circle; a camera fixed on the circle lost it within 3 s. Every
    # frame of 10 s shows the whole disk, away from the picture's edges.
    env = gym.make(rd.ENV_ID, task="circle", actuators=(), render_mode="rgb_array")
    env.reset(seed=0)
    distances = []
    for _ in range(rd.MAX_EPISODE_STEPS):
        _, _, terminated, _, info = env.step(np.zeros(0, dtype=np.float32))
        assert not terminated
        frame = env.render()
        mask = np.all(frame == DISK, axis=-1) | np.all(frame == RIM, axis=-1)  # edge-on, the rim is most of it
        rows, columns = np.nonzero(mask)
        assert mask.sum() > 40
        assert rows.min() > 0 and rows.max() < mask.shape[0] - 1
        assert columns.min() > 0 and columns.max() < mask.shape[1] - 1
        distances.append(np.hypot(info["state"][0], info["state"][1]) - env.unwrapped.goal["radius"])
    assert max(distances) > 5  # the disk did leave the circle, by more than its radius


def test_the_camera_frames_the_target_circle_while_the_disk_is_near_it():
    env = gym.make(rd.ENV_ID, task="circle", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    target = np.all(frame == TARGET, axis=-1)
    rows, columns = np.nonzero(target)
    # The whole circle is in the picture: its leftmost and rightmost points are away from the edges.
    assert columns.min() > 5 and columns.max() < frame.shape[1] - 6
    assert rows.min() > 5 and rows.max() < frame.shape[0] - 6


@pytest.mark.parametrize("task", ["upright", "circle"])
def test_a_legend_explains_the_shadow_and_the_wall_projection(task):
    env = gym.make(rd.ENV_ID, task=task, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    renderer = env.unwrapped._renderer
    assert renderer.legend_entries("target circle" if task == "circle" else None) == [
        "shadow on the ground",
        "projection on a wall (along +y)",
        "track of the centre",
        *(["target circle"] if task == "circle" else []),
    ]
    assert np.all(frame == LEGEND_BACKGROUND, axis=-1).sum() > 3000
