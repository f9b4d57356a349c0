"""Pygame scene of RollingDisk-v0: a perspective view of the disk on its ground plane.

Drawn back to front: a ground grid (1 m squares), the task's marks (its target circle, targets, waypoints or figure
eight: :meth:`rolling_disk_env.tasks.Task.marks`), the centre's track, the disk's two projections as in the paper's
figure 1 (in black: its shadow straight down on the ground and its projection along +y on a vertical wall behind
it), then the disk itself with a spoke and a rim marker that turn with the spin phi. A text line gives time, lean and
rates; a legend explains the colours. The camera follows the disk smoothly, framing the task's marks as well while
the disk is near them. ``"rgb_array"`` draws on an off-screen surface and never opens a
display.
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
LEGEND_BACKGROUND = (250, 251, 253)
WALL_DISTANCE = 3.0
"""The wall of the vertical projection stands this many radii beyond the disk, along +y (away from the camera)."""
LEGEND = {
    "shadow": "shadow on the ground",
    "wall": "projection on a wall (along +y)",
    "track": "track of the centre",
}
"""What the legend explains, by what it draws beside each line; the task's marks (its ``mark_label``) go last."""
FRAMED_FROM = 2.0
"""Disk radii. The camera frames the task's marks with the disk when they spread over at least this much (a point
target's small circle does not)."""
LEGEND_LINE = 14
"""Pixels per line of the legend."""
LEGEND_TOP = 30
"""Pixel row of the legend's top in the upper left corner, below the text line."""
CAMERA_LAG = 0.5
"""s. The camera's look-at point and distance approach their targets with this time constant."""
CIRCLE_VIEW = np.array([0.0, -0.9, 0.55]) / math.hypot(0.9, 0.55)
"""Direction from the look-at point to the eye with a target circle: looking along +y, the wall behind the disk."""
DISK_VIEW = np.array([-0.55, -0.7, 0.45]) / math.hypot(0.55, 0.7, 0.45)
"""The same without a target circle: from the side and behind, along +x and +y."""


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


def framing(points: np.ndarray, direction: np.ndarray, top: float) -> tuple[np.ndarray, float]:
    """A look-at point and the smallest distance (m) along ``direction`` from it at which a camera sees all
    ``points`` (n, 3) in the picture below the pixel row ``top``, with 10 pixels to spare elsewhere, centred there.

    A point at ``x`` right of, ``y`` above and ``z`` beyond the look-at point, seen from ``d`` away, lands
    ``focal x / (z + d)`` pixels right of the picture's centre (and likewise up): each edge gives the smallest ``d``
    per point. Starting at the centre of the points' box, the look-at point then moves so that the points' picture
    is centred (perspective makes the near side look larger), twice.
    """
    camera = Camera(direction, np.zeros(3))  # the camera's axes depend on the direction only
    margin = 10
    half_width, above, below = WIDTH / 2 - margin, HEIGHT / 2 - top, HEIGHT / 2 - margin
    focus = (points.min(axis=0) + points.max(axis=0)) / 2
    for _ in range(3):
        relative = points - focus
        x, y, z = relative @ camera.right, relative @ camera.up, relative @ camera.forward
        needed = camera.focal * np.maximum.reduce([np.abs(x) / half_width, y / above, -y / below]) - z
        distance = max(0.5, float(needed.max()))
        u, v = camera.focal * x / (z + distance), -camera.focal * y / (z + distance)  # from the picture's centre
        shift_u = (u.min() + u.max()) / 2
        shift_v = (v.min() + v.max()) / 2 - (top - margin) / 2
        focus = focus + distance / camera.focal * (shift_u * camera.right - shift_v * camera.up)
    return focus, distance


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
        self.legend_font = pygame.font.Font(None, 16)
        self._focus: np.ndarray | None = None
        self._distance = 0.0
        self._time = 0.0

    @staticmethod
    def _framed(marks: list[np.ndarray], params: DiskParams) -> np.ndarray | None:
        """The points of the task's marks the camera frames, (n, 2), or None where they spread over less than
        :data:`FRAMED_FROM` disk radii."""
        if not marks:
            return None
        points = np.vstack(marks)
        extent = np.linalg.norm(points.max(axis=0) - points.min(axis=0)) / 2
        return points if extent >= FRAMED_FROM * params.radius else None

    def _view(self, state, params: DiskParams, framed: np.ndarray | None) -> tuple[np.ndarray, float]:
        """Where the camera should look (m, world) and from how far (m): framing the marks' points ``framed`` and the
        disk while the disk is within twice their half-extent of their centre, else the disk alone."""
        r = params.radius
        disk = np.array([state[0], state[1], 0.6 * r])
        if framed is None:
            return disk, 7 * r
        low, high = framed.min(axis=0), framed.max(axis=0)
        if np.linalg.norm(disk[:2] - (low + high) / 2) > np.linalg.norm(high - low):
            return disk, 12 * r
        step = max(1, len(framed) // 48)
        ground = np.column_stack([framed[::step], np.zeros(len(framed[::step]))])
        corners = np.array([[dx, dy, dz] for dx in (-r, r) for dy in (-r, r) for dz in (0.0, 2 * r)])
        points = np.vstack([ground, disk * [1, 1, 0] + corners])
        # Below the text line and the legend, which sit in the upper left corner of this view.
        return framing(points, CIRCLE_VIEW, top=LEGEND_TOP + LEGEND_LINE * (len(LEGEND) + 1) + 12)

    def _camera(self, time: float, state, params: DiskParams, framed: np.ndarray | None) -> Camera:
        """The camera of a frame at ``time`` (s): its look-at point and distance follow :meth:`_view` with the lag
        :data:`CAMERA_LAG`, and never so far behind that the disk leaves the picture; a new episode (time not
        after the previous frame's) starts on the view."""
        target, distance = self._view(state, params, framed)
        if self._focus is None or time <= self._time:
            self._focus, self._distance = target, distance
        else:
            weight = 1.0 - math.exp(-(time - self._time) / CAMERA_LAG)
            self._focus = self._focus + weight * (target - self._focus)
            self._distance += weight * (distance - self._distance)
            # The look-at point stays within a third of the picture's half-height of where it should be.
            lag = self._focus - target
            limit = self._distance * math.tan(FIELD_OF_VIEW / 2) / 3
            if np.linalg.norm(lag) > limit:
                self._focus = target + lag * (limit / np.linalg.norm(lag))
        self._time = time
        direction = CIRCLE_VIEW if framed is not None else DISK_VIEW
        return Camera(self._focus + self._distance * direction, self._focus)

    def draw(self, time: float, state, params: DiskParams, goal: dict, task, track) -> np.ndarray | None:
        """Draws one frame of ``state`` (8 floats) at ``time`` (s) with the disk ``params``, the task's marks for its
        ``goal`` and the centre's track (a sequence of (c1, c2), m)."""
        pygame = self.pygame
        surface = self.surface
        surface.fill(BACKGROUND)
        marks = task.marks(goal)
        camera = self._camera(time, state, params, self._framed(marks, params))

        self._draw_grid(camera)
        for mark in marks:
            ground = np.column_stack([mark, np.zeros(len(mark))])
            pygame.draw.lines(surface, TARGET, False, camera.project(ground).tolist(), 2)
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
        self._draw_legend(task.mark_label if marks else None)

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
    def legend_entries(marks: str | None) -> list[str]:
        """The legend's lines, with the task's marks' (their label ``marks``) if there are any."""
        return [*LEGEND.values(), *([marks] if marks else [])]

    def _draw_legend(self, marks: str | None) -> None:
        """What the colours mean, in the corner the scene leaves emptiest: upper left when looking over the task's
        marks (their far side looks narrowest), lower right when looking at the disk from the side (the wall is
        upper left)."""
        pygame, surface = self.pygame, self.surface
        entries = list(zip([*LEGEND, "marks"], self.legend_entries(marks)))
        line, swatch, pad = LEGEND_LINE, 20, 4
        labels = [self.legend_font.render(label, True, TEXT) for _, label in entries]
        width = swatch + 6 + max(label.get_width() for label in labels) + 2 * pad
        height = line * len(entries) + 2 * pad
        left, top = (8, LEGEND_TOP) if marks else (WIDTH - width - 8, HEIGHT - height - 8)
        pygame.draw.rect(surface, LEGEND_BACKGROUND, (left, top, width, height))
        pygame.draw.rect(surface, GRID, (left, top, width, height), 1)
        for row, ((kind, _), label) in enumerate(zip(entries, labels)):
            x, y = left + pad, top + pad + row * line
            middle = y + line // 2 - 1
            if kind == "shadow":
                pygame.draw.ellipse(surface, SHADOW, (x, middle - 4, swatch, 8))
            elif kind == "wall":
                pygame.draw.rect(surface, WALL, (x, y + 1, swatch, line - 3))
                pygame.draw.ellipse(surface, SHADOW, (x + 6, y + 3, 10, line - 7))
            else:
                pygame.draw.line(surface, TRACK if kind == "track" else TARGET, (x, middle), (x + swatch, middle), 2)
            surface.blit(label, (x + swatch + 6, y + (line - label.get_height()) // 2))

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
