"""Pygame scene of RollingDisk-v0: a perspective view of the disk on its ground plane.

Drawn back to front: a ground grid (1 m squares), the task's target circle, the centre's track, the disk's two
projections as in the paper's figure 1 (in black: its shadow straight down on the ground and its projection along +y
on a vertical wall behind it),
then the disk itself with a spoke and a rim marker that turn with the spin phi. A text line gives time, lean and
rates. ``"rgb_array"`` draws on an off-screen surface and never opens a display.
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium.error import DependencyNotInstalled

from rolling_disk_env.dynamics import DiskParams, rotation_matrix

WIDTH, HEIGHT = 600, 400
FIELD_OF_VIEW = math.radians(50)
BACKGROUND = (235, 240, 245)
GRID = (200, 205, 212)
WALL = (215, 220, 228)
TARGET = (40, 160, 80)
TRACK = (220, 120, 30)
SHADOW = (25, 25, 30)
DISK = (40, 90, 200)
RIM = (15, 35, 110)
SPOKE = (250, 250, 250)
TEXT = (20, 20, 20)
WALL_DISTANCE = 3.0
"""The wall of the vertical projection stands this many radii beyond the disk, along +y (away from the camera)."""


def rim_points(state, radius: float, count: int = 48) -> np.ndarray:
    """The rim of the disk in world coordinates, shape (count, 3), starting at the spoke (body axis R e2) (m)."""
    rotation = rotation_matrix(*state[2:5])
    e2, e3 = rotation[:, 1], rotation[:, 2]
    angles = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    centre = np.array([state[0], state[1], radius * math.cos(state[3])])
    return centre + radius * (np.outer(np.cos(angles), e2) + np.outer(np.sin(angles), e3))


class Camera:
    """A pinhole camera at ``eye`` looking at ``target``, z up; projects world points (m) to pixels."""

    def __init__(self, eye: np.ndarray, target: np.ndarray):
        forward = target - eye
        self.forward = forward / np.linalg.norm(forward)
        right = np.cross(self.forward, [0.0, 0.0, 1.0])
        self.right = right / np.linalg.norm(right)
        self.up = np.cross(self.right, self.forward)
        self.eye = eye
        self.target = target
        self.focal = WIDTH / (2 * math.tan(FIELD_OF_VIEW / 2))

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates of points of shape (n, 3); points behind the camera are pushed in front of it."""
        relative = np.atleast_2d(points) - self.eye
        depth = np.maximum(relative @ self.forward, 0.05)
        u = WIDTH / 2 + self.focal * (relative @ self.right) / depth
        v = HEIGHT / 2 - self.focal * (relative @ self.up) / depth
        return np.stack([u, v], axis=1)


class DiskRenderer:
    """Draws frames; ``"human"`` shows them in a window at ``fps``, ``"rgb_array"`` returns them."""

    def __init__(self, render_mode: str, fps: int):
        try:
            import pygame
        except ImportError as error:
            raise DependencyNotInstalled(
                'pygame is not installed: run `pip install "gymnasium[classic-control]"`'
            ) from error
        self.pygame = pygame
        self.render_mode = render_mode
        self.fps = fps
        pygame.font.init()
        self.font = pygame.font.Font(None, 20)
        if render_mode == "human":
            pygame.display.init()
            pygame.display.set_caption("RollingDisk-v0")
            self.window = pygame.display.set_mode((WIDTH, HEIGHT))
            self.clock = pygame.time.Clock()
        self.surface = pygame.Surface((WIDTH, HEIGHT))

    def _camera(self, state, params: DiskParams, goal: dict) -> Camera:
        if "radius" in goal:
            centre = np.array([goal["cx"], goal["cy"], 0.0])
            distance = 2.2 * goal["radius"] + 4 * params.radius
            return Camera(centre + distance * np.array([0.0, -0.9, 0.55]), centre)
        target = np.array([state[0], state[1], params.radius * 0.6])
        distance = 7 * params.radius
        return Camera(target + distance * np.array([-0.55, -0.7, 0.45]), target)

    def draw(self, time: float, state, params: DiskParams, goal: dict, task, track) -> np.ndarray | None:
        """Draws one frame of ``state`` (8 floats) at ``time`` (s) with the disk ``params``, the task's ``goal``
        and the centre's track (a sequence of (c1, c2), m)."""
        pygame = self.pygame
        surface = self.surface
        surface.fill(BACKGROUND)
        camera = self._camera(state, params, goal)

        self._draw_grid(camera)
        if "radius" in goal:
            angles = np.linspace(0, 2 * math.pi, 96)
            circle = np.stack(
                [
                    goal["cx"] + goal["radius"] * np.cos(angles),
                    goal["cy"] + goal["radius"] * np.sin(angles),
                    np.zeros_like(angles),
                ],
                axis=1,
            )
            pygame.draw.lines(surface, TARGET, True, camera.project(circle).tolist(), 2)
        if track is not None and len(track) > 1:
            points = np.array(track)
            path = np.column_stack([points, np.zeros(len(points))])
            pygame.draw.lines(surface, TRACK, False, camera.project(path).tolist(), 2)

        rim = rim_points(state, params.radius)
        shadow = rim.copy()
        shadow[:, 2] = 0.0
        pygame.draw.polygon(surface, SHADOW, camera.project(shadow).tolist())
        wall_y = state[1] + WALL_DISTANCE * params.radius
        width, height = 4 * params.radius, 2.5 * params.radius
        panel = np.array(
            [
                [state[0] - width, wall_y, 0],
                [state[0] + width, wall_y, 0],
                [state[0] + width, wall_y, height],
                [state[0] - width, wall_y, height],
            ]
        )
        pygame.draw.polygon(surface, WALL, camera.project(panel).tolist())
        wall = rim.copy()
        wall[:, 1] = wall_y
        pygame.draw.polygon(surface, SHADOW, camera.project(wall).tolist())

        outline = camera.project(rim).tolist()
        pygame.draw.polygon(surface, DISK, outline)
        pygame.draw.polygon(surface, RIM, outline, 2)
        centre = camera.project(rim.mean(axis=0))[0].tolist()
        pygame.draw.line(surface, SPOKE, centre, outline[0], 3)
        pygame.draw.circle(surface, SPOKE, [int(v) for v in outline[0]], 5)

        text = (
            f"t {time:5.2f} s   lean {math.degrees(state[3]):+6.1f} deg   spin rate {state[5]:+5.2f} rad/s"
            f"   heading rate {state[7]:+5.2f} rad/s   task {task.name}"
        )
        surface.blit(self.font.render(text, True, TEXT), (8, 8))

        if self.render_mode == "human":
            pygame.event.pump()
            self.window.blit(surface, (0, 0))
            pygame.display.flip()
            self.clock.tick(self.fps)
            return None
        return np.transpose(np.array(pygame.surfarray.pixels3d(surface)), axes=(1, 0, 2))

    def _draw_grid(self, camera: Camera) -> None:
        span = 12
        ox, oy = math.floor(camera.target[0]), math.floor(camera.target[1])
        for k in range(-span, span + 1):
            for start, end in (((ox + k, oy - span), (ox + k, oy + span)), ((ox - span, oy + k), (ox + span, oy + k))):
                segment = np.array([[*start, 0.0], [*end, 0.0]])
                segment = self._clip_in_front(camera, segment)
                if segment is not None:
                    self.pygame.draw.line(self.surface, GRID, *camera.project(segment).tolist(), 1)

    @staticmethod
    def _clip_in_front(camera: Camera, segment: np.ndarray) -> np.ndarray | None:
        """The part of a segment at least 0.5 m in front of the camera, or None."""
        depth = (segment - camera.eye) @ camera.forward - 0.5
        if depth.max() <= 0:
            return None
        if depth.min() < 0:
            near, far = (0, 1) if depth[0] < 0 else (1, 0)
            fraction = depth[far] / (depth[far] - depth[near])
            segment = segment.copy()
            segment[near] = segment[far] + fraction * (segment[near] - segment[far])
        return segment

    def close(self) -> None:
        if self.render_mode == "human":
            self.pygame.display.quit()
