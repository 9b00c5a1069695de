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
Labels from dcmppi.control.dbscan: sklearn's labels, compiled with numba for two features
(~50x faster), sklearn itself for the N + 1 features of time-varying perturbations. The
per-cluster weights and updates are numba loops too (one pass over the clustered samples).
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
    """DBSCAN features (K, nu + 1) or (K, N nu + 1).

    Args:
      eps: (N, nu, K) projected perturbations (time-major). S: (K,) costs.
      sigma: (nu,) perturbation standard deviations. raw: (nu, K) constant perturbations, if any.
    """
    n, nu, k = eps.shape
    sigma = np.asarray(sigma, dtype=float).reshape(-1)
    if raw is not None:
        if np.shape(raw) != (nu, len(S)):
            raise ValueError(f"raw must be (nu, K) = ({nu}, {len(S)}); got {np.shape(raw)}")
        if nu == 1:
            return _constant_features(raw[0], S, sigma[0], lambda_, cost_clip).T
        cost = np.minimum((S - S.min()) / lambda_, cost_clip)
        return np.column_stack([(raw / sigma[:, None]).T, cost])
    cost = np.minimum((S - S.min()) / lambda_, cost_clip)
    scale = np.repeat(sigma[None, :] * np.sqrt(n), n, axis=0).reshape(-1)
    return np.column_stack([np.reshape(eps, (n * nu, k)).T / scale, cost])


@numba.njit(cache=True)
def _constant_features(raw, S, sigma, lambda_, cost_clip):
    """(2, K) rows raw / sigma and min((S - min S) / lambda, cost_clip) (contiguous rows: the
    columns of the (K, 2) features that dbscan reads)."""
    features = np.empty((2, len(S)))
    least = S.min()
    for k in range(len(S)):
        features[0, k] = raw[k] / sigma
        features[1, k] = min((S[k] - least) / lambda_, cost_clip)
    return features


def cluster_labels(features, dbscan_eps=DBSCAN_EPS, min_samples=DBSCAN_MIN_SAMPLES):
    """DBSCAN labels (K,), -1 for noise, for (K, d) features."""
    return dbscan(features, dbscan_eps, min_samples)


def cluster_updates(U0, eps, S, lambda_, labels, raw=None, bound=None):
    """Alg. 1 inside every cluster (Alg. 2 lines 12-14).

    Args:
      U0: (N, nu). eps: (N, nu, K). S: (K,). labels: (K,) with M clusters 0..M-1 and noise -1.
      raw, bound: for one control with constant perturbations and symmetric bounds, the
        scalar samples (K,) and the control bound: eps[:, 0, k] is then recomputed as
        clip(U0 + raw_k, -bound, bound) - U0 (the same values, without reading down the
        columns of the (N, 1, K) array).
    Returns:
      U: (M, N, nu) control sequence per cluster; w: (K,) each sample's weight within its own
      cluster (each cluster's weights sum to 1; noise points 0).
    """
    N, nu, K = eps.shape
    if np.shape(U0) != (N, nu) or S.shape != (K,) or labels.shape != (K,):
        raise ValueError(
            f"cluster_updates needs U0 (N, nu), S (K,) and labels (K,) for eps (N, nu, K) = "
            f"{eps.shape}; got {np.shape(U0)}, {S.shape}, {labels.shape}"
        )
    if raw is not None and (nu != 1 or np.shape(raw) != (K,)):
        raise ValueError(f"raw needs one control and shape (K,) = ({K},); got {np.shape(raw)}")
    M = int(labels.max()) + 1 if K else 0
    w = _cluster_exponents(S, labels, M, lambda_)
    np.exp(w, out=w)  # numpy's vectorised exp: several times faster than numba's scalar one
    if raw is None:
        raw, bound = np.zeros(0), 0.0
    flat = np.reshape(eps, (N * nu, K))
    U = _cluster_sums(np.reshape(U0, N * nu), flat, raw, float(bound), w, labels, M)
    return U.reshape(M, N, nu), w


@numba.njit(cache=True)
def _cluster_exponents(S, labels, M, lambda_):
    """(K,) (rho_c - S_k) / lambda for the clustered samples k, rho_c: the least cost of k's
    cluster c; -inf for noise points (their exp is 0)."""
    rho = np.full(M, np.inf)
    for k in range(len(S)):
        if labels[k] >= 0:
            rho[labels[k]] = min(rho[labels[k]], S[k])
    exponent = np.full(len(S), -np.inf)
    for k in range(len(S)):
        if labels[k] >= 0:
            exponent[k] = (rho[labels[k]] - S[k]) / lambda_
    return exponent


@numba.njit(cache=True)
def _cluster_sums(U0, eps, raw, bound, w, labels, M):
    """Normalises the exp terms w (K,) per cluster in place (sums in index order) and returns
    U (M, N) = U0 + sum_k w_k eps_k over each cluster's samples (eps_k from raw when given).

    Every sample belongs to at most one cluster, so U costs one multiply-add per clustered sample
    and step (a dense (M, K) x (K, N) product would spend M times that on zero weights).
    """
    N, K = eps.shape
    eta = np.zeros(M)
    for k in range(K):
        if labels[k] >= 0:
            eta[labels[k]] += w[k]
    U = np.zeros((M, N))
    for k in range(K):
        c = labels[k]
        if c >= 0:
            w[k] /= eta[c]
            if len(raw):
                for i in range(N):
                    U[c, i] += w[k] * (min(max(U0[i] + raw[k], -bound), bound) - U0[i])
            else:
                for i in range(N):
                    U[c, i] += w[k] * eps[i, k]
    for c in range(M):
        for i in range(N):
            U[c, i] += U0[i]
    return U


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
        raw = self._raw
        features = cluster_features(eps, S, self.lambda_, self.sigma, self.cost_clip, raw)
        labels = cluster_labels(features, self.dbscan_eps, self.dbscan_min_samples)
        self.record(eps, states, J, S)
        d = self.diagnostics
        d.labels = labels
        if labels.max(initial=-1) < 0:  # no cluster: Alg. 1 over all samples
            plan, w = mppi_update(self.U, eps, S, self.lambda_)
            d.chosen, d.cluster_controls = -1, np.zeros((0, self.N, self.nu))
            d.cluster_costs = np.zeros(0)
        else:
            agent = self.agent
            scalar = raw is not None and agent.nu == 1 and agent.lower[0] == -agent.upper[0]
            U, w = cluster_updates(
                self.U, eps, S, self.lambda_, labels, raw[0] if scalar else None, agent.upper[0]
            )
            _, Jm = self.evaluate(state, U.transpose(1, 2, 0))
            best = int(np.argmin(Jm))
            plan, w = U[best], np.where(labels == best, w, 0.0)
            d.chosen, d.cluster_controls, d.cluster_costs = best, U, Jm
        d.weights, d.ess = w, effective_sample_size(w)
        return self.finish(plan)
