"""Clustered MPPI (paper Alg. 2): DBSCAN over the rollouts, Alg. 1 inside each cluster.

The data point of sample k is d_k = [eps_k, S_k] (paper Sec. III-A), scaled so that one rule
works at every step, for every agent and perturbation (docs/design.md):
- perturbation: for each control, the applied (projected) perturbation averaged over the
  horizon, in units of that average's sampling std (constant: sqrt(Sigma); time-varying:
  sqrt(Sigma / N); mixed: sqrt(Sigma (1 + 1 / N) / 2)). Before projection these are standard normal
  in nu dimensions.
- cost: (S_k - min S) in units of cost_unit / (collision_gap x radius), cost_unit = alpha by
  default: a rollout with one more colliding state lies `collision_gap` DBSCAN radii away from an
  otherwise equal one, while the goal-distance part of the cost varies smoothly. The
  moving-obstacle term M_k of S_k (the objective's way term included) is measured in its own
  unit, the prediction's collision_cost (frozen obstacles: alpha; sampled futures: beta): the
  cost feature is
  (S_k - M_k) / cost_unit + M_k / collision_cost (times collision_gap x radius), so a state
  certainly inside a moving obstacle (all its P futures) moves a sample as far as a static
  collision does, and one of P futures 1 / P of that. Measured in alpha, beta = alpha / 10
  would move it half a radius, inside one DBSCAN ball (docs/design.md). So a value peak
  and its flanks (samples that pass the obstacle, farther and farther out) stay one cluster,
  and the ridge of samples through an obstacle is cut off from both peaks (paper Fig. 2: "sharp
  changes in the cost will cause a new cluster boundary").
DBSCAN: radius dbscan_eps, by default the radius of the ball that holds 16 % of a standard
normal in nu dimensions (0.202 for one control, 0.591 for two, 0.916 for three: the same share
of the samples around the centre of the sampling distribution for every agent; the paper asks
for clusters below 20 % of the samples); min_samples dbscan_min_samples. Noise points (label
-1) belong to no cluster, except the lowest-cost sample: when DBSCAN finds clusters but leaves it
noise (a sample in the sparse tail of the sampling distribution), it and the noise points within
the radius of it form one more cluster, so the best rollout is always a candidate (the best
sample is never a noise point). With no cluster at all the step falls back to Alg. 1 over all
samples.
Each cluster's control sequence is rolled out without noise and the one with the least cost J
is applied; with hysteresis > 0, the one that continues the warm start unless another's J is
lower by more than that margin. Labels from dcmppi.control.kernels.dbscan (sklearn's labels,
compiled with numba); the features (their horizon sums come from the projection pass),
per-cluster weights and updates are numba loops.
"""

import math

import numba
import numpy as np
from scipy.special import gammaincinv

from dcmppi.control.kernels.dbscan import dbscan
from dcmppi.control.kernels.projection import horizon_sums
from dcmppi.control.planners.diagnostics import ClusteredDiagnostics
from dcmppi.control.planners.mppi import MPPI, effective_sample_size, mppi_update
from dcmppi.control.planners.registry import register
from dcmppi.control.planners.smoothing import Hysteresis
from dcmppi.control.validation import positive

DBSCAN_SHARE = 0.16  # share of a standard normal inside the default DBSCAN radius
DBSCAN_MIN_SAMPLES = 5  # neighbours (self included) of a core sample
COLLISION_GAP = 5.0  # DBSCAN radii between rollouts one colliding state apart


def dbscan_radius(controls):
    """Default DBSCAN radius for `controls` perturbation features: the ball holding
    DBSCAN_SHARE of a standard normal in that many dimensions."""
    return math.sqrt(2.0 * gammaincinv(controls / 2, DBSCAN_SHARE))  # chi2.ppf, as scipy.stats


def mean_std(sigma, perturbation, N, correlation=0.0):
    """Sampling std (nu,) of a horizon-mean perturbation, for per-step stds sigma (nu,) (and
    the correlation a of "correlated" ones: the mean of a^|i - j| over the N^2 pairs of steps)."""
    if perturbation == "correlated":
        a = correlation
        factor = ((1 + a) / (1 - a) - 2 * a * (1 - a**N) / (N * (1 - a) ** 2)) / N
    else:
        factor = {"constant": 1.0, "time_varying": 1.0 / N, "mixed": 0.5 * (1.0 + 1.0 / N)}[
            perturbation
        ]
    return np.asarray(sigma, dtype=float) * math.sqrt(factor)


def cluster_features(eps, S, scale, cost_scale):
    """DBSCAN features (K, nu + 1): the horizon-mean perturbation of each control divided by
    `scale` (nu,), and (S - min S) * cost_scale.

    Args:
      eps: (N, nu, K) applied perturbations (time-major). S: (K,) costs.
    """
    n, nu, k = eps.shape
    scale = np.asarray(scale, dtype=float).reshape(-1)
    if scale.shape != (nu,) or np.shape(S) != (k,):
        raise ValueError(
            f"cluster_features needs scale (nu,) and S (K,) for eps (N, nu, K) = {eps.shape}; "
            f"got {scale.shape}, {np.shape(S)}"
        )
    return features_of_sums(horizon_sums(eps), S, 1.0 / (n * scale), float(cost_scale))


@numba.njit(cache=True)
def features_of_sums(sums, S, inv, cost_scale):
    """cluster_features from the horizon sums (nu, K) of the perturbations; inv (nu,) =
    1 / (N scale)."""
    nu, k = sums.shape
    out = np.empty((k, nu + 1))
    least = S.min()
    for m in range(k):
        for j in range(nu):
            out[m, j] = sums[j, m] * inv[j]
        out[m, nu] = (S[m] - least) * cost_scale
    return out


def cluster_labels(features, dbscan_eps, min_samples=DBSCAN_MIN_SAMPLES, best=None):
    """DBSCAN labels (K,), -1 for noise, for (K, d) features. With `best` (the index of the
    lowest-cost sample), when there are clusters but the best sample is noise, it and the noise
    points within dbscan_eps of it get a cluster of their own."""
    labels = dbscan(features, dbscan_eps, min_samples)
    if best is not None and labels[best] < 0 <= labels.max(initial=-1):
        gap = features - features[best]
        near = (labels < 0) & (np.einsum("kd,kd->k", gap, gap) <= dbscan_eps * dbscan_eps)
        labels[near] = labels.max(initial=-1) + 1
    return labels


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
    np.exp(w, out=w)  # numpy's exp, as mppi_weights' (vectorised with AVX-512; performance.md)
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

    Extra args (see the module docstring): dbscan_eps (None: the default radius for the
    agent's number of controls), dbscan_min_samples, collision_gap, cost_unit (None: alpha);
    and hysteresis in the choice of candidate (docs/design.md, Smoothness): a cost margin >= 0
    (0: none, the default; `preset="smooth"`: 50): the candidate that continues the warm start
    (the nearest to it, smoothing.continuing) is kept unless another's noise-free cost J is
    lower by more than the margin (smoothing.Hysteresis).
    """

    own_params = ("dbscan_eps", "dbscan_min_samples", "collision_gap", "cost_unit", "hysteresis")
    diagnostics_class = ClusteredDiagnostics

    def __init__(
        self,
        *,
        dbscan_eps=None,
        dbscan_min_samples=DBSCAN_MIN_SAMPLES,
        collision_gap=COLLISION_GAP,
        cost_unit=None,
        hysteresis=None,
        **params,
    ):
        super().__init__(**params)
        self.hysteresis = positive(
            "hysteresis", self.option("hysteresis", hysteresis, 0.0), allow_zero=True
        )
        self.choice = Hysteresis(self.hysteresis, self.Sigma)
        self.dbscan_eps = (
            dbscan_radius(self.nu) if dbscan_eps is None else positive("dbscan_eps", dbscan_eps)
        )
        self.dbscan_min_samples = positive("dbscan_min_samples", dbscan_min_samples, integer=True)
        self.collision_gap = positive("collision_gap", collision_gap)
        if cost_unit is None and not self.alpha:
            raise ValueError("cost_unit is needed when alpha = 0 (it defaults to alpha)")
        self.cost_unit = self.alpha if cost_unit is None else positive("cost_unit", cost_unit)
        sigma = self.sampler.sigma
        self._feature_scale = mean_std(sigma, self.perturbation, self.N, self.correlation)
        self._feature_inv = 1.0 / (self.N * self._feature_scale)
        self._cost_scale = self.collision_gap * self.dbscan_eps / self.cost_unit

    def _solve(self, state):
        timer = self.timer
        r = self.perturbed_rollouts(state, sums=True)
        eps, S = r.e, r.J + r.importance
        with timer("features"):
            unit = self.objective.prediction.unit
            cost = (
                S
                if r.moving is None or unit == self.cost_unit or not unit
                else S + r.moving * (self.cost_unit / unit - 1.0)
            )  # moving-obstacle term in units of the prediction's collision_cost (0: no term)
            features = features_of_sums(r.sums, cost, self._feature_inv, self._cost_scale)
        with timer("DBSCAN"):
            best = int(np.argmin(S))
            labels = cluster_labels(features, self.dbscan_eps, self.dbscan_min_samples, best)
        self.record(eps, r.states, r.J, S)
        d = self.diagnostics
        d.labels, d.features = labels, features
        lam = d.lambda_ = self.temperature(S)  # one lambda, over all samples, for every cluster
        if labels.max(initial=-1) < 0:  # no cluster: Alg. 1 over all samples
            with timer("update"):
                plan, w = mppi_update(self.U, eps, S, lam)
            plan = self.mean_speeds(plan, r.u, w)
            d.chosen, d.continued = -1, -1
            d.cluster_controls = np.zeros((0, self.N, self.nu))
            d.cluster_costs = np.zeros(0)
        else:
            agent, raw = self.agent, self.sampler.raw
            scalar = raw is not None and agent.nu == 1 and agent.lower[0] == -agent.upper[0]
            with timer("cluster updates"):
                U, w = cluster_updates(
                    self.U, eps, S, lam, labels, raw[0] if scalar else None, agent.upper[0]
                )
            U = self.mean_speeds(U, r.u, w, labels)
            _, Jm = self.rollout_costs(state, U.transpose(1, 2, 0))
            best, d.continued = self.choice(Jm, U, self.U)
            plan, w = U[best], np.where(labels == best, w, 0.0)
            d.chosen, d.cluster_controls, d.cluster_costs = best, U, Jm
        d.weights, d.ess = w, effective_sample_size(w)
        return self.finish(plan)
