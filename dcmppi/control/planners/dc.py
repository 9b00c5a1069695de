"""DC-MPPI (paper Alg. 3): Clustered MPPI (Alg. 2) with sampled futures of the moving obstacles
in the cost, i.e. `clustered` with prediction="prior" (dcmppi.control.predictors.prior).

The futures come from the predictor: "prior" (the paper's: speeds and turn rates from the known
Gaussian) by default, or "ekf" (each obstacle's own Gaussian-sum filter), or any registered one.
"""

from dcmppi.control.planners.clustered import ClusteredMPPI
from dcmppi.control.planners.registry import register


@register("dc")
class DCMPPI(ClusteredMPPI):
    """DC-MPPI, paper Alg. 3: ClusteredMPPI's parameters, prediction "prior" by default."""

    default_prediction = "prior"
