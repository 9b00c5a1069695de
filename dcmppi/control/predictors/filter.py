"""Moving obstacles estimated from noisy positions: one EKF per obstacle (paper Sec. IV-B).

The state of an obstacle is s = (x, y, theta, v, omega): position, heading, speed and turn rate
of the Dubins obstacle model (speed and turn rate constant). Its step over the period dt between
measurements is the exact arc

    a = omega dt / 2,  x += v dt sinc(a) cos(theta + a),  y += v dt sinc(a) sin(theta + a),
    theta += omega dt,

with Jacobian F = ds'/ds (`dubins_transition`). Measurements are positions only,
z = (x, y) + N(0, measurement_std^2 I).

Heading. The population prior (obstacle_model: speed ~ N(v_mean, v_std^2), turn rate
~ N(omega_mean, omega_std^2)) says nothing of the heading, which is uniform, and positions reveal
it only once the obstacle has moved a few measurement stds (about 1 s at 0.1 m and 1 m/s). One
Gaussian cannot hold a uniform heading, and an EKF linearised far from the true heading is
overconfident, so each obstacle's posterior is a Gaussian sum of HEADINGS components, each an
EKF: component m starts at heading 2 pi m / HEADINGS with std pi / HEADINGS (half the spacing),
at the first measured position (std measurement_std) and at the prior's speed and turn rate.
Every measurement multiplies a component's weight by its likelihood; within a second or two the
weight sits on the components near the true heading. A component whose speed estimate turns
negative is rewritten as the same motion with heading + pi and speed -v.

Reflections. The crowd's obstacles bounce off the walls (heading mirrored), which the model does
not predict. When the heaviest component's normalised innovation nu^T S^-1 nu exceeds GATE (tail
1e-4 of the chi-square with 2 degrees of freedom: one false alarm per 1000 s of an obstacle),
the obstacle's heading is spread over the bank again at the measured position, keeping its
speed and turn-rate estimates from before that measurement.

Process noise: a random walk of `process_std` per sqrt(s) on every state (default PROCESS_STD).
For the crowd's Dubins obstacles the model is exact between reflections; the small default
keeps the covariances positive definite and lets a heading that is slightly off recover.
Pedestrians swerve and change speed: their process noise must be larger (design.md).

A component's weight stays at least exp(LOG_WEIGHT_FLOOR) times the heaviest one's (negligible,
and never a subnormal number, whose arithmetic is slow).

Each step is one numpy pass over all L obstacles and their components (batched 5 x 5 matrices).
"""

import numpy as np

from dcmppi.control.kernels.dynamics import sinc, wrap_angle
from dcmppi.control.kernels.normal import standard_normal
from dcmppi.control.predictors.base import check_obstacle_model
from dcmppi.control.validation import positive

STATE = ("x", "y", "heading", "speed", "turn_rate")
HEADINGS = 8  # heading components per obstacle
PROCESS_STD = np.array([0.01, 0.01, 0.01, 0.003, 0.003])  # per sqrt(s): m, m, rad, m/s, rad/s
GATE = 2.0 * np.log(1e4)  # normalised innovation beyond which a track is lost (p = 1e-4)
LOG_WEIGHT_FLOOR = -500.0  # relative log weight of a component, at least (no subnormal weights)
MEASUREMENT_STD = 0.1  # [m] default position noise std of the obstacle sensor


def sinc_derivative(a):
    """d sinc(a) / da = (cos a - sinc a) / a, elementwise, by its series near 0."""
    a = np.asarray(a, dtype=float)
    small = np.abs(a) < 1e-2
    safe = np.where(small, 1.0, a)
    a2 = a * a
    return np.where(small, a * (-1.0 / 3.0 + a2 / 30.0), (np.cos(safe) - sinc(safe)) / safe)


def dubins_transition(s, dt):
    """The exact arc of the Dubins obstacle model over dt, and its Jacobian.

    Args:
      s: (..., 5) x, y, theta, v, omega.
    Returns:
      (..., 5) the next states (theta not wrapped) and F (..., 5, 5) = ds'/ds.
    """
    s = np.asarray(s, dtype=float)
    theta, v, omega = s[..., 2], s[..., 3], s[..., 4]
    a = 0.5 * dt * omega
    c, dc = sinc(a), sinc_derivative(a)
    cos, sin = np.cos(theta + a), np.sin(theta + a)
    chord = dt * v * c
    nxt = s.copy()
    nxt[..., 0] += chord * cos
    nxt[..., 1] += chord * sin
    nxt[..., 2] += dt * omega
    F = np.zeros(s.shape + (5,))
    F[..., range(5), range(5)] = 1.0
    half = 0.5 * dt * dt * v
    F[..., 0, 2], F[..., 1, 2] = -chord * sin, chord * cos
    F[..., 0, 3], F[..., 1, 3] = dt * c * cos, dt * c * sin
    F[..., 0, 4] = half * (dc * cos - c * sin)
    F[..., 1, 4] = half * (dc * sin + c * cos)
    F[..., 2, 4] = dt
    return nxt, F


def collapse(means, covs, log_weights):
    """Mean (L, 5) and covariance (L, 5, 5) of each obstacle's Gaussian sum.

    means: (L, M, 5); covs: (L, M, 5, 5); log_weights: (L, M), normalised. Headings are
    averaged as offsets from the heaviest component's heading; the mean heading is wrapped.
    """
    w = np.exp(log_weights)
    L, M = w.shape
    ref = means[np.arange(L), np.argmax(log_weights, axis=1), 2][:, None]
    m = means.copy()
    m[..., 2] = ref + wrap_angle(means[..., 2] - ref)
    mean = (w[:, None] @ m)[:, 0]
    d = (m - mean[:, None]) * np.sqrt(w)[..., None]  # (L, M, 5) weighted spreads
    cov = (w[:, None] @ covs.reshape(L, M, 25)).reshape(L, 5, 5) + d.swapaxes(1, 2) @ d
    mean[:, 2] = wrap_angle(mean[:, 2])
    return mean, cov


def check_process_std(value) -> tuple:
    """process_std as 5 floats > 0 (x, y, heading, speed, turn rate per sqrt(s)), or one clear
    ValueError."""
    try:
        std = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        std = np.full(1, np.nan)
    if std.shape != (5,) or not (np.isfinite(std) & (std > 0)).all():
        raise ValueError(
            "process_std must be 5 finite numbers > 0 (x, y [m], heading [rad], speed [m/s], "
            f"turn rate [rad/s], per sqrt(s)); got {value!r}"
        )
    return tuple(std.tolist())


class ObstacleFilter:
    """Gaussian-sum EKF of L moving obstacles from their measured positions (module docstring).

    Args:
      obstacle_model: (4,) v_mean, v_std, omega_mean, omega_std: the population prior.
      measurement_std: std of each measured coordinate [m], > 0.
      dt: time between measurements [s].
      headings: components per obstacle (M).
      process_std: (5,) random-walk std per sqrt(s) of x, y, heading, speed, turn rate, > 0.
    Attributes (after the first update): means (L, M, 5), covs (L, M, 5, 5) and log_weights
    (L, M) of the components (`posterior()`: the whole posterior's moments).
    """

    def __init__(
        self, obstacle_model, measurement_std, dt, headings=HEADINGS, process_std=PROCESS_STD
    ):
        self.model = check_obstacle_model(obstacle_model, "ekf")
        self.measurement_std = positive("measurement_std", measurement_std)
        self.dt = positive("dt", dt)
        self.headings = positive("headings", headings, integer=True)
        process_std = np.array(check_process_std(process_std))
        self.process_std = process_std
        self._Q = np.diag(process_std**2 * self.dt)
        self.means = self.covs = self.log_weights = None

    def __len__(self):
        return 0 if self.means is None else len(self.means)

    def posterior(self):
        """Mean (L, 5) and covariance (L, 5, 5) of every obstacle's posterior."""
        return collapse(self.means, self.covs, self.log_weights)

    def update(self, z):
        """Takes one measurement of every obstacle, dt after the previous one.

        z: (L, 2) measured x, y, in the same obstacle order at every call. The first call starts
        the filter from the prior; later ones predict dt ahead and correct.
        """
        z = np.asarray(z, dtype=float)
        if z.ndim != 2 or z.shape[1] != 2:
            raise ValueError(f"measurements must be (L, 2) positions x, y; got shape {z.shape}")
        bad = ~np.isfinite(z).all(axis=1)
        if bad.any():
            raise ValueError(f"measured positions must be finite; bad rows {np.flatnonzero(bad)}")
        if self.means is None:
            v_mean, v_std, w_mean, w_std = self.model
            one = np.ones(len(z))
            self.means, self.covs, self.log_weights = self._spread(
                z, v_mean * one, v_std**2 * one, w_mean * one, w_std**2 * one
            )
            return
        if len(z) != len(self.means):
            raise ValueError(
                f"{len(z)} obstacles measured, {len(self.means)} tracked: the observation must "
                "keep the number and order of the obstacles (reset the filter for a new episode)"
            )
        self.means, F = dubins_transition(self.means, self.dt)
        self.covs = F @ self.covs @ F.swapaxes(-1, -2) + self._Q
        self._correct(z)

    def sample(self, rng, P):
        """P states (L, P, 5) of each obstacle drawn from its posterior (component by weight,
        then the component's Gaussian)."""
        L, M = self.log_weights.shape
        cumulative = np.cumsum(np.exp(self.log_weights), axis=1)
        u = rng.random((L, P))
        component = np.minimum((u[..., None] > cumulative[:, None, :]).sum(axis=-1), M - 1)
        rows = np.arange(L)[:, None]
        try:
            roots = np.linalg.cholesky(self.covs)
        except np.linalg.LinAlgError:  # a variance of 0 (a speed known exactly): C = A A^T
            w, V = np.linalg.eigh(self.covs)
            roots = V * np.sqrt(np.maximum(w, 0.0))[..., None, :]
        chol = roots[rows, component]  # (L, P, 5, 5)
        z = standard_normal(rng, (L, P, 5))
        return self.means[rows, component] + np.einsum("lpij,lpj->lpi", chol, z)

    def _spread(self, z, speed, speed_var, turn, turn_var):
        """Components at positions z (n, 2), headings over the bank, speeds and turn rates (n,)
        with variances (n,): means (n, M, 5), covs (n, M, 5, 5), log weights (n, M)."""
        n, M = len(z), self.headings
        means = np.empty((n, M, 5))
        means[..., :2] = z[:, None]
        means[..., 2] = wrap_angle(2.0 * np.pi * np.arange(M) / M)
        means[..., 3] = speed[:, None]
        means[..., 4] = turn[:, None]
        covs = np.zeros((n, M, 5, 5))
        covs[..., 0, 0] = covs[..., 1, 1] = self.measurement_std**2
        covs[..., 2, 2] = (np.pi / M) ** 2
        covs[..., 3, 3] = speed_var[:, None]
        covs[..., 4, 4] = turn_var[:, None]
        return means, covs, np.full((n, M), -np.log(M))

    def _correct(self, z):
        """EKF update of every component with z (L, 2); weights by likelihood; lost tracks
        re-spread."""
        P = self.covs
        nu = z[:, None] - self.means[..., :2]  # (L, M, 2)
        S = P[..., :2, :2] + self.measurement_std**2 * np.eye(2)
        det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
        S_inv = np.stack([S[..., 1, 1], -S[..., 0, 1], -S[..., 1, 0], S[..., 0, 0]], axis=-1)
        S_inv = S_inv.reshape(S.shape) / det[..., None, None]
        gain = P[..., :, :2] @ S_inv  # (L, M, 5, 2)
        nis = np.einsum("lmi,lmij,lmj->lm", nu, S_inv, nu)
        lost = nis[np.arange(len(nis)), np.argmax(self.log_weights, axis=1)] > GATE
        if lost.any():
            before = collapse(self.means[lost], P[lost], self.log_weights[lost])
        self.means = self.means + np.einsum("lmij,lmj->lmi", gain, nu)
        P = P - gain @ P[..., :2, :]
        self.covs = 0.5 * (P + P.swapaxes(-1, -2))
        log_w = self.log_weights - 0.5 * (nis + np.log(det))
        log_w = np.maximum(log_w - log_w.max(axis=1, keepdims=True), LOG_WEIGHT_FLOOR)
        self.log_weights = log_w - np.log(np.exp(log_w).sum(axis=1, keepdims=True))
        self._canonical()
        if lost.any():
            mean, cov = before
            self.means[lost], self.covs[lost], self.log_weights[lost] = self._spread(
                z[lost], mean[:, 3], cov[:, 3, 3], mean[:, 4], cov[:, 4, 4]
            )

    def _canonical(self):
        """Components with negative speed as heading + pi, speed -v; headings wrapped."""
        flip = self.means[..., 3] < 0
        if flip.any():
            self.means[flip, 2] += np.pi
            self.means[flip, 3] *= -1.0
            sign = np.where(flip, -1.0, 1.0)[..., None]
            self.covs[..., 3, :] *= sign
            self.covs[..., :, 3] *= sign
        self.means[..., 2] = wrap_angle(self.means[..., 2])
