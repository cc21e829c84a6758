"""The arena of the ball-seeking experiment: floor, walls, clutter, a pink and an orange ball.

Everything is placed from a seed, so the same seed gives the same arena. Clutter is static and
coloured away from the balls' hues (no reds, oranges, pinks or purples) so that perception's
colour thresholds see only the balls. Shapes are boxes and spheres: few triangles keep the
tiny renderer fast.
"""
from __future__ import annotations

import numpy as np

HALF_SIZE = 1.5  # metres from the centre to each wall
WALL_HEIGHT, WALL_THICKNESS = 0.25, 0.04
BALL_RADIUS, BALL_MASS = 0.04, 0.05
BALL_COLOURS = {"pink": (1.0, 0.41, 0.71, 1.0), "orange": (1.0, 0.5, 0.0, 1.0)}
FLOOR_COLOUR, WALL_COLOUR = (0.72, 0.70, 0.65, 1.0), (0.80, 0.82, 0.86, 1.0)
CLUTTER_COLOURS = ((0.2, 0.3, 0.75, 1), (0.2, 0.55, 0.3, 1), (0.35, 0.35, 0.38, 1), (0.1, 0.45, 0.5, 1), (0.9, 0.9, 0.9, 1))
CLUTTER_COUNT = 7
KEEP_CLEAR = 0.5  # no clutter or ball this close to where the robot starts (the origin)
HIDDEN_AT = (40.0, 40.0)  # far outside the camera's range, on the same infinite floor


class Arena:
    """Builds the scene in a PyBullet client; `balls` maps colour name to body id."""

    def __init__(self, client, seed: int):
        self._client = client
        self.rng = np.random.default_rng(seed)
        self._occupied: list[tuple[np.ndarray, float]] = []  # (centre, radius) of what stands on the floor
        self._build_floor_and_walls()
        self.clutter = [self._place_clutter(i) for i in range(CLUTTER_COUNT)]
        self.balls = {name: self._make_ball(rgba) for name, rgba in BALL_COLOURS.items()}
        for name in self.balls:
            spot = self._free_spot(margin=0.1)
            self._occupied.append((np.array(spot), BALL_RADIUS))
            self.place_ball(name, spot)

    def _static_box(self, half_extents, position, rgba, collide=True) -> int:
        c = self._client
        visual = c.createVisualShape(c.GEOM_BOX, halfExtents=half_extents, rgbaColor=rgba)
        collision = c.createCollisionShape(c.GEOM_BOX, halfExtents=half_extents) if collide else -1
        return c.createMultiBody(0, collision, visual, position)

    def _build_floor_and_walls(self) -> None:
        c = self._client
        plane = c.createCollisionShape(c.GEOM_PLANE)
        visual = c.createVisualShape(c.GEOM_BOX, halfExtents=[HALF_SIZE + 0.5, HALF_SIZE + 0.5, 0.001], rgbaColor=FLOOR_COLOUR)
        self.floor = c.createMultiBody(0, plane, visual, [0, 0, 0])
        c.changeDynamics(self.floor, -1, lateralFriction=1.0)
        # the visual box's top sits 1 mm above the collision plane: hidden feet would look odd
        c.resetBasePositionAndOrientation(self.floor, [0, 0, -0.001], [0, 0, 0, 1])
        reach = HALF_SIZE + WALL_THICKNESS / 2
        for sign in (-1, 1):
            self._static_box([WALL_THICKNESS / 2, reach, WALL_HEIGHT / 2], [sign * reach, 0, WALL_HEIGHT / 2], WALL_COLOUR)
            self._static_box([reach, WALL_THICKNESS / 2, WALL_HEIGHT / 2], [0, sign * reach, WALL_HEIGHT / 2], WALL_COLOUR)

    def _free_spot(self, margin: float) -> tuple[float, float]:
        """A random floor point away from the robot's start, the walls and the clutter."""
        for _ in range(1000):
            xy = self.rng.uniform(-HALF_SIZE + 0.2, HALF_SIZE - 0.2, size=2)
            if np.hypot(*xy) < KEEP_CLEAR + margin:
                continue
            if all(np.hypot(*(xy - spot)) > size + margin for spot, size in self._occupied):
                return float(xy[0]), float(xy[1])
        raise RuntimeError("arena too crowded to place another object; lower CLUTTER_COUNT")

    def _place_clutter(self, i: int) -> int:
        half = self.rng.uniform([0.04, 0.04, 0.03], [0.12, 0.12, 0.12])
        x, y = self._free_spot(margin=float(np.hypot(half[0], half[1])))
        self._occupied.append((np.array([x, y]), float(np.hypot(half[0], half[1]))))
        rgba = CLUTTER_COLOURS[int(self.rng.integers(len(CLUTTER_COLOURS)))]
        body = self._static_box(half.tolist(), [x, y, half[2]], rgba)
        yaw = float(self.rng.uniform(0, np.pi))
        self._client.resetBasePositionAndOrientation(body, [x, y, half[2]], self._client.getQuaternionFromEuler([0, 0, yaw]))
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
        return {name: np.array(self._client.getBasePositionAndOrientation(body)[0]) for name, body in self.balls.items()}
