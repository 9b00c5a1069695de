"""The numbers of docs/design.md, in one place for tasks, controllers and runner.

Paper values are marked (paper); the rest are choices the paper leaves open.
Names follow the paper: K samples, N horizon steps, lambda_, Sigma, alpha, beta, P.
"""

import math

# Robots (docs/design.md; shared by the plants in tasks/ and the agents in control/agents/).
V = 1.0  # dubins: constant forward speed v [m/s] (paper Fig. 4)
R_MIN = 1.0  # dubins: minimum turning radius [m]; |omega| <= V / R_MIN
UNICYCLE_V_MAX = 1.0  # unicycle: 0 <= v <= v_max [m/s]
UNICYCLE_OMEGA_MAX = 1.0  # unicycle: |omega| <= omega_max [rad/s]
HOLONOMIC_V_MAX = 1.5  # holonomic: |(u_x, u_y)| <= v_max [m/s] (docs/design.md, Experiments)
HOLONOMIC_OMEGA_MAX = 1.0  # holonomic: |u_theta| <= omega_max [rad/s]
ROBOT_RADIUS = 0.5  # robot collision radius [m]
DT = 0.1  # control period [s]
PHYSICS_TIMESTEP = 0.01  # MuJoCo timestep [s] -> 10 substeps per control step
GOAL_TOLERANCE = 1.0  # goal reached within this distance [m]
TIME_LIMIT_FACTOR = 3.0  # time limit = 3 x map perimeter / v (paper)

# Noise profiles of the experiments (docs/design.md, Experiments).
NOISE_PROFILES = ("none", "control", "process")
CONTROL_NOISE = 0.1  # variance of the control noise on every control, in its own units (paper)

# Maps (docs/design.md, Experiments).
MAP_SIZE = (75.0, 50.0)  # [m], x in [0, 75], y in [0, 50]
MIN_START_GOAL_DISTANCE = 30.0

# Controllers.
K = 500  # samples (paper)
N = 50  # horizon steps, 5 s (chosen)
LAMBDA = 1.0  # lambda, cost sensitivity (paper)
SIGMA = 0.1  # Sigma, variance of a turn-rate perturbation [(rad/s)^2] (paper)
SIGMA_VELOCITY = 1.0  # Sigma of a velocity perturbation [(m/s)^2] (docs/design.md)
GAMMA = 1.0  # gamma, weight of the importance term (1: the paper's Alg. 2)
ALPHA = 1000.0  # alpha, static collision weight (paper)
BETA = 100.0  # beta, dynamic collision weight (paper: 10, nearly inert at this cost scale)
P = 25  # sampled futures per moving obstacle (paper)

# Moving obstacles of the crowd (docs/design.md, Experiments): uniform ranges, and the Gaussian
# with the same mean and standard deviation that the controllers are told.
OBSTACLE_SPEED_RANGE = (0.5, 1.5)  # [m/s]
OBSTACLE_TURN_RATE_RANGE = (-0.5, 0.5)  # [rad/s]
MOVING_OBSTACLE_RADIUS = 1.0  # [m]


def uniform_mean_std(lo: float, hi: float) -> tuple[float, float]:
    """Mean and standard deviation of U(lo, hi)."""
    return 0.5 * (lo + hi), (hi - lo) / math.sqrt(12.0)


def omega_max(v: float = V, r_min: float = R_MIN) -> float:
    """Turn-rate bound v / R_min [rad/s]."""
    return v / r_min
