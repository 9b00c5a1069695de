"""Clustered MPPI (paper Alg. 2): DBSCAN over the rollouts, Alg. 1 inside each cluster.

Features (SPEC section 2), scaled so one DBSCAN radius works at every step:
- perturbation: the sample's perturbation in units of its standard deviation. With constant
  perturbations (the default) a sample has one degree of freedom, its scalar eps_k / sqrt(Sigma)
  (before clipping; the clipped sequence is a monotone function of it). With time-varying ones,
  the clipped sequence divided by sqrt(Sigma N), so distances are RMS values over the horizon.
- cost: min((S_k - min S) / lambda, cost_clip). Samples whose weight exp(-(S - rho)/lambda) is
  negligible all sit at the clip, so the high-cost ridge between good modes forms its own cluster
  instead of bridging them.
DBSCAN: radius dbscan_eps, min_samples dbscan_min_samples; noise points (label -1) belong to no
cluster; with no cluster at all the step falls back to Alg. 1 over all samples. Each cluster's
control sequence is rolled out without noise and the one with the least cost J is applied.
Labels from dcmppi.dbscan: sklearn's labels, compiled with numba for two features (~50x faster),
sklearn itself for the N + 1 features of time-varying perturbations. The per-cluster weights
are numba loops too (numpy's exp and matrix product keep the values of the numpy version).
"""

import numba
import numpy as np

from .controllers import _positive, register
from .dbscan import dbscan
from .mppi import MPPI, effective_sample_size, mppi_update

DBSCAN_EPS = 0.2  # neighbourhood radius in feature units
DBSCAN_MIN_SAMPLES = 5  # neighbours (self included) of a core sample
COST_CLIP = 10.0  # clip of (S - min S) / lambda


def cluster_features(eps, S, lambda_, sigma, cost_clip=COST_CLIP, raw=None):
    """DBSCAN features (K, 2) or (K, N + 1).

    Args:
      eps: (N, K) clipped perturbations (time-major). S: (K,) costs.
      sigma: perturbation standard deviation. raw: (K,) scalar constant perturbations, if any.
    """
    if raw is not None:
        features = np.empty((2, len(S)))  # returned transposed: contiguous columns for dbscan
        np.divide(raw, sigma, out=features[0])
        np.subtract(S, S.min(), out=features[1])
        features[1] /= lambda_
        np.minimum(features[1], cost_clip, out=features[1])
        return features.T
    cost = np.minimum((S - S.min()) / lambda_, cost_clip)
    return np.column_stack([eps.T / (sigma * np.sqrt(len(eps))), cost])


def cluster_labels(features, dbscan_eps=DBSCAN_EPS, min_samples=DBSCAN_MIN_SAMPLES):
    """DBSCAN labels (K,), -1 for noise, for (K, d) features."""
    return dbscan(features, dbscan_eps, min_samples)


def cluster_updates(U0, eps, S, lambda_, labels):
    """Alg. 1 inside every cluster (Alg. 2 lines 12-14).

    Args:
      U0: (N,). eps: (N, K). S: (K,). labels: (K,) with M clusters 0..M-1 and noise -1.
    Returns:
      U: (M, N) control sequence per cluster; W: (M, K) weights (each row sums to 1).
    """
    M = int(labels.max()) + 1 if len(labels) else 0
    exponent = _cluster_exponents(S, labels, M, lambda_)
    np.exp(exponent, out=exponent)  # numpy's exp: the same values as Alg. 1's weights
    W = _cluster_weights(exponent, labels, M)
    U = W @ eps.T
    U += U0
    return U, W


@numba.njit(cache=True)
def _cluster_exponents(S, labels, M, lambda_):
    """(rho_c - S_k) / lambda for the clustered samples k in index order, rho_c: the least cost
    of k's cluster c. Returns (members,)."""
    rho = np.full(M, np.inf)
    members = 0
    for k in range(len(S)):
        if labels[k] >= 0:
            rho[labels[k]] = min(rho[labels[k]], S[k])
            members += 1
    exponent = np.empty(members)
    m = 0
    for k in range(len(S)):
        if labels[k] >= 0:
            exponent[m] = (rho[labels[k]] - S[k]) / lambda_
            m += 1
    return exponent


@numba.njit(cache=True)
def _cluster_weights(w, labels, M):
    """(M, K) weights: the clustered samples' exp terms w (members,), normalised per cluster
    (sums in index order); zero outside each sample's cluster."""
    total = np.zeros(M)
    m = 0
    for k in range(len(labels)):
        if labels[k] >= 0:
            total[labels[k]] += w[m]
            m += 1
    W = np.zeros((M, len(labels)))
    m = 0
    for k in range(len(labels)):
        if labels[k] >= 0:
            W[labels[k], k] = w[m] / total[labels[k]]
            m += 1
    return W


@register("clustered")
class ClusteredMPPI(MPPI):
    """Clustered MPPI, paper Alg. 2.

    Extra args: dbscan_eps, dbscan_min_samples, cost_clip (see the module docstring).
    """

    own_params = ("dbscan_eps", "dbscan_min_samples", "cost_clip")

    def __init__(
        self,
        *,
        dbscan_eps=DBSCAN_EPS,
        dbscan_min_samples=DBSCAN_MIN_SAMPLES,
        cost_clip=COST_CLIP,
        **params,
    ):
        self.dbscan_eps = _positive("dbscan_eps", dbscan_eps)
        self.dbscan_min_samples = _positive("dbscan_min_samples", dbscan_min_samples, integer=True)
        self.cost_clip = _positive("cost_clip", cost_clip)
        super().__init__(**params)

    def _solve(self, state):
        eps, states, J, S = self.rollouts(state)
        raw = self._raw if self.perturbation == "constant" else None
        features = cluster_features(eps, S, self.lambda_, self.sigma, self.cost_clip, raw)
        labels = cluster_labels(features, self.dbscan_eps, self.dbscan_min_samples)
        self.record(eps, states, J, S)
        d = self.diagnostics
        d.labels = labels
        if labels.max(initial=-1) < 0:  # no cluster: Alg. 1 over all samples
            plan, w = mppi_update(self.U, eps, S, self.lambda_)
            d.chosen, d.cluster_controls, d.cluster_costs = -1, np.zeros((0, self.N)), np.zeros(0)
        else:
            U, W = cluster_updates(self.U, eps, S, self.lambda_, labels)
            _, Jm = self.evaluate(state, U.T)
            best = int(np.argmin(Jm))
            plan, w = U[best], W[best]
            d.chosen, d.cluster_controls, d.cluster_costs = best, U, Jm
        d.weights, d.ess = w, effective_sample_size(w)
        return self.finish(plan)
