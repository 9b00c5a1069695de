"""`square`: a robot crossing a square that pedestrians cross too (C-Uniform's scene)."""

from . import worlds
from .base import PedestrianNavigation

SQUARE_V_MAX = 1.0  # [m/s] the holonomic robot's default top speed here (C-Uniform's scene)


class Square(PedestrianNavigation):
    """8 x 8 m, open; the robot drives from 1 m inside one side to 1 m inside the opposite one.

    `n_pedestrians` walk between uniform random points of the square, a new goal on arrival,
    at preferred speeds uniform in `speed_range` (`worlds.generate_square`); the
    observation's `obstacle_model` is the Gaussian of those speeds with turn rates
    N(0, worlds.PEDESTRIAN_TURN_RATE_STD^2). The robot is holonomic with v_max
    SQUARE_V_MAX (slower than most pedestrians) and radius 0.3 m by default; see
    `PedestrianNavigation` for `behavior` (default "orca"), `robot_visible` and the time limit.
    """

    size = worlds.SQUARE_SIZE
    generate = staticmethod(worlds.generate_square)

    def __init__(
        self,
        n_pedestrians=worlds.SQUARE_PEDESTRIANS,
        pedestrian_radius=worlds.PEDESTRIAN_RADIUS,
        speed_range=worlds.SQUARE_SPEED_RANGE,
        behavior="orca",
        robot_visible=False,
        robot_radius=worlds.PEDESTRIAN_RADIUS,
        **kwargs,
    ):
        if (kwargs.get("agent") or self.default_agent) == "holonomic":
            kwargs.setdefault("v_max", SQUARE_V_MAX)
        super().__init__(
            n_pedestrians,
            pedestrian_radius,
            speed_range,
            behavior,
            robot_visible,
            robot_radius=robot_radius,
            **kwargs,
        )

    def world_params(self) -> dict:
        return {"speed_range": self.speed_range, "radius": self.radius}
