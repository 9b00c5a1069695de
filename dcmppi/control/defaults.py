"""The planners' defaults of docs/design.md, and the robots' numbers that the agents here and
the plants of dcmppi.tasks share.

The world's numbers (map size, crowd ranges, physics timestep, goal tolerance, noise profiles)
belong to the tasks (dcmppi.tasks: worlds.base, worlds.paper, pedestrians.worlds, navigation).
Paper values are marked (paper); the rest are choices the paper leaves open.
Names follow the paper: K samples, N horizon steps, lambda_, Sigma, alpha, beta, P.
"""

# Robots (docs/design.md; shared by the plants in tasks/ and the agents in control/agents/).
V = 1.0  # dubins: constant forward speed v [m/s] (paper Fig. 4)
R_MIN = 1.0  # dubins: minimum turning radius [m]; |omega| <= V / R_MIN
UNICYCLE_V_MAX = 1.0  # unicycle: 0 <= v <= v_max [m/s]
UNICYCLE_OMEGA_MAX = 1.0  # unicycle: |omega| <= omega_max [rad/s]
HOLONOMIC_V_MAX = 1.5  # holonomic: |(u_x, u_y)| <= v_max [m/s] (docs/design.md, Experiments)
HOLONOMIC_OMEGA_MAX = 1.0  # holonomic: |u_theta| <= omega_max [rad/s]
ROBOT_RADIUS = 0.5  # robot collision radius [m]
DT = 0.1  # control period [s]

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
CORRELATION = 0.9  # step-to-step correlation of "correlated" perturbations (docs/design.md)


def omega_max(v: float = V, r_min: float = R_MIN) -> float:
    """Turn-rate bound v / R_min [rad/s]."""
    return v / r_min


# Presets: named sets of the options above that a controller takes with `preset=` (explicit
# parameters win). "paper": the paper's algorithms, every default above (the default preset).
# "smooth": plans a robot can follow (docs/design.md, Smoothness), chosen on environments outside
# the experiments' and the same for every planner: correlated perturbations (CORRELATION), the
# temperature chosen each step at an ESS of 5 % of K, nav2's Savitzky-Golay filter of the plan
# (9 steps, quadratic), and for the clustered planners hysteresis of 50 cost units (about 1 m less
# progress at every state) in the choice of cluster.
PRESETS = {
    "paper": {},
    "smooth": {
        "perturbation": "correlated",
        "lambda_": "auto",
        "ess_target": 0.05,
        "filter_window": 9,
        "filter_order": 2,
        "hysteresis": 50.0,
    },
}
# "crowds": the setting for a robot among people (docs/pedestrians.md, The crowds preset), chosen
# on tuning environments across the MPPI-family rows: "smooth", plus an update at the samples'
# mean speed (speed_mean "polar", holonomic robots), a weak importance term (gamma 0.1, which
# otherwise favours samples slower than the warm start), half the default beta (a shorter detour
# round predicted people) with a cost for standing in their way (way_weight 1, which keeps them
# from being cut off), the safety shield (its defaults) and, for constant-velocity futures, the
# recordings' spread: 0.2 m/s for people walking, 0.1 m/s for people standing (docs/crowds.md,
# Standing people).
PRESETS["crowds"] = {
    **PRESETS["smooth"],
    "gamma": 0.1,
    "speed_mean": "polar",
    "shield": True,
    "cv_std": 0.2,
    "cv_std_still": 0.1,
    "beta": 50.0,
    "way_weight": 1.0,
}
