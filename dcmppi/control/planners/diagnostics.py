"""What a control step leaves for plots, videos and the bench: one record per kind of planner.

Arrays are kept by reference (not copied). K samples, N steps, nu controls.
"""

import dataclasses

import numpy as np


@dataclasses.dataclass
class Diagnostics:
    """The last control step of MPPI (paper Alg. 1), the base of every planner's record.

    eps: (K, N, nu) perturbations actually applied (projected into the control bounds).
    states: (K, N + 1, 3) rollout states.
    J: (K,) costs; S: (K,) costs plus the importance term.
    weights: (K,) weights that produced the plan (zero outside the chosen cluster).
    ess: effective sample size 1 / sum(weights^2).
    lambda_: the temperature of the weights (lambda_, or the step's choice with "auto").
    warm_start: (N, nu) the reference controls U0 the step started from (eps is relative to it).
    plan: (N, nu) the optimised control sequence; action: (nu,) the applied controls.
    prediction: the step's dcmppi.control.Prediction of the moving obstacles (tracks, and the
      sampled futures and filter posterior where the predictor makes them).
    shielded: whether the safety shield changed the planner's command (None: no shield).
    """

    eps: np.ndarray = None
    states: np.ndarray = None
    J: np.ndarray = None
    S: np.ndarray = None
    weights: np.ndarray = None
    ess: float = float("nan")
    lambda_: float = float("nan")
    warm_start: np.ndarray = None
    plan: np.ndarray = None
    action: np.ndarray = None
    prediction: object = None
    shielded: bool = None


@dataclasses.dataclass
class ClusteredDiagnostics(Diagnostics):
    """Clustered MPPI and DC-MPPI (paper Alg. 2 and 3): Diagnostics, and

    labels: (K,) DBSCAN labels (-1: noise); features: (K, nu + 1) the points DBSCAN clustered.
    cluster_controls: (M, N, nu) and cluster_costs: (M,) per-cluster sequences and their J.
    chosen: index of the chosen cluster, -1 for the fallback to Alg. 1 over all samples.
    continued: with hysteresis, the index of the cluster that continues the warm start (-1:
      none, or no hysteresis).
    """

    labels: np.ndarray = None
    features: np.ndarray = None
    cluster_controls: np.ndarray = None
    cluster_costs: np.ndarray = None
    chosen: int = -1
    continued: int = -1


@dataclasses.dataclass
class TubeDiagnostics(Diagnostics):
    """Tube-MPPI: Diagnostics, and nominal_state: (3,), nominal_reset: bool and
    nominal_deviation: the real-to-nominal position distance at the start of the step, before
    any reset [m]."""

    nominal_state: np.ndarray = None
    nominal_reset: bool = None
    nominal_deviation: float = float("nan")
