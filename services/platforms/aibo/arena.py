"""The arena of the ball-seeking experiment: floor, walls, clutter, a pink and an orange ball.

Everything is placed from a seed, so the same seed gives the same arena. Clutter is static and
coloured away from the balls' hues (no reds, oranges, pinks or purples) so that perception's
colour thresholds see only the balls. Shapes are boxes and spheres: few triangles keep the
tiny renderer fast.
"""
from __future__ import annotations

import numpy as np

from services.platforms.aibo.arena_layout import BALL_RADIUS, HALF_SIZE, arena_layout

WALL_HEIGHT, WALL_THICKNESS = 0.25, 0.04
BALL_MASS = 0.05
BALL_COLOURS = {"pink": (1.0, 0.41, 0.71, 1.0), "orange": (1.0, 0.5, 0.0, 1.0)}
FLOOR_COLOUR, WALL_COLOUR = (0.72, 0.70, 0.65, 1.0), (0.80, 0.82, 0.86, 1.0)
HIDDEN_AT = (40.0, 40.0)  # far outside the camera's range, on the same infinite floor


class Arena:
    """Builds the scene in a PyBullet client; `balls` maps colour name to body id."""

    def __init__(self, client, seed: int):
        self._client = client
        self.layout = arena_layout(seed)
        self._build_floor_and_walls()
        self.clutter = [self._place_clutter(box) for box in self.layout.clutter]
        self.balls = {name: self._make_ball(rgba) for name, rgba in BALL_COLOURS.items()}
        for name, spot in self.layout.balls.items():
            self.place_ball(name, spot)

    def _static_box(self, half_extents, position, rgba, collide=True) -> int:
        c = self._client
        visual = c.createVisualShape(c.GEOM_BOX, halfExtents=half_extents, rgbaColor=rgba)
        collision = c.createCollisionShape(c.GEOM_BOX, halfExtents=half_extents) if collide else -1
        return c.createMultiBody(0, collision, visual, position)

    def _build_floor_and_walls(self) -> None:
        c = self._client
        plane = c.createCollisionShape(c.GEOM_PLANE)
        visual = c.createVisualShape(c.GEOM_BOX, halfExtents=[HALF_SIZE + 0.5, HALF_SIZE + 0.5, 0.001],
                                     rgbaColor=FLOOR_COLOUR)
        self.floor = c.createMultiBody(0, plane, visual, [0, 0, 0])
        c.changeDynamics(self.floor, -1, lateralFriction=1.0)
        # the visual box's top sits 1 mm above the collision plane: hidden feet would look odd
        c.resetBasePositionAndOrientation(self.floor, [0, 0, -0.001], [0, 0, 0, 1])
        reach = HALF_SIZE + WALL_THICKNESS / 2
        for sign in (-1, 1):
            self._static_box([WALL_THICKNESS / 2, reach, WALL_HEIGHT / 2], [sign * reach, 0, WALL_HEIGHT / 2],
                             WALL_COLOUR)
            self._static_box([reach, WALL_THICKNESS / 2, WALL_HEIGHT / 2], [0, sign * reach, WALL_HEIGHT / 2],
                             WALL_COLOUR)

    def _place_clutter(self, box) -> int:
        body = self._static_box(list(box.half), list(box.centre), box.rgba)
        self._client.resetBasePositionAndOrientation(body, list(box.centre), self._client.getQuaternionFromEuler([0, 0,
                                                                                                                  box.yaw]))
        return body

    def _make_ball(self, rgba) -> int:
        c = self._client
        visual = c.createVisualShape(c.GEOM_SPHERE, radius=BALL_RADIUS, rgbaColor=rgba)
        collision = c.createCollisionShape(c.GEOM_SPHERE, radius=BALL_RADIUS)
        body = c.createMultiBody(BALL_MASS, collision, visual, [0, 0, BALL_RADIUS])
        # rolling friction and damping stop a nudged ball within a second or two, like on carpet
        c.changeDynamics(body, -1, lateralFriction=0.8, rollingFriction=0.002, linearDamping=0.3, angularDamping=0.3)
        return body

    def place_ball(self, name: str, xy) -> None:
        """Put a ball at rest on the floor at `xy` (world metres)."""
        if name not in self.balls:
            raise KeyError(f"no ball named {name!r}; the arena has {', '.join(self.balls)}")
        body = self.balls[name]
        self._client.resetBasePositionAndOrientation(body, [float(xy[0]), float(xy[1]), BALL_RADIUS], [0, 0, 0, 1])
        self._client.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0])

    def hide_ball(self, name: str) -> None:
        """Take a ball out of play (parked far outside the walls, beyond the camera's range)."""
        offset = list(self.balls).index(name)
        self.place_ball(name, (HIDDEN_AT[0] + offset, HIDDEN_AT[1]))

    def ball_positions(self) -> dict[str, np.ndarray]:
        return {name: np.array(self._client.getBasePositionAndOrientation(body)[0]) for name,
                body in self.balls.items()}
