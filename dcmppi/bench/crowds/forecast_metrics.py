"""Forecast metrics of sampled futures against the truth, per window.

ADE / FDE: the mean over the predicted steps / the last step of the distance [m] between a
forecast and the truth; "most likely" scores one point forecast, "best of P" the sample of the
smallest ADE (FDE: of the smallest FDE), as Social-GAN reports them.

The whole sample set, per predicted step: a Gaussian kernel density estimate of the P samples
with Scott's bandwidth matrix H = P^(-1/3) C + BANDWIDTH_FLOOR^2 I (C the samples' covariance,
Scott's rule in two dimensions; the floor keeps one sample or identical ones a density);
- NLL: the negative log density of the true position, log density clipped below at
  LOG_DENSITY_FLOOR as Trajectron++ clips it, averaged over the steps [nats];
- coverage: the fraction of steps whose true position lies in the KDE's 90 % highest-density
  region, {y: f(y) >= f_10}, f_10 the 10 % quantile of f at HDR_DRAWS points drawn from the KDE
  (Hyndman 1996); a calibrated forecast covers 0.9.
"""

import numpy as np

BANDWIDTH_FLOOR = 0.1  # [m]: the kernel's smallest std, about the annotation's error
LOG_DENSITY_FLOOR = -20.0  # [log(1/m^2)]
HDR_MASS = 0.9
HDR_DRAWS = 100
CHUNK = 2048  # (window, step) pairs per vectorised block


def displacement(samples, truth, point) -> dict:
    """Per-window ADE and FDE [m] of the point forecast and of the best sample.

    samples: (M, P, T, 2); truth: (M, T, 2); point: (M, T, 2).
    Returns {"ade", "fde", "min_ade", "min_fde"} each (M,).
    """
    error = np.linalg.norm(point - truth, axis=-1)  # (M, T)
    errors = np.linalg.norm(samples - truth[:, None], axis=-1)  # (M, P, T)
    return {
        "ade": error.mean(axis=1),
        "fde": error[:, -1],
        "min_ade": errors.mean(axis=2).min(axis=1),
        "min_fde": errors[:, :, -1].min(axis=1),
    }


def kde_scores(samples, truth, seed=0) -> dict:
    """Per-window KDE NLL and 90 % HDR coverage of the samples (module docstring).

    samples: (M, P, T, 2); truth: (M, T, 2); seed: of the draws that place the HDR threshold.
    Returns {"nll", "coverage"} each (M,).
    """
    M, P, T, _ = samples.shape
    means = samples.transpose(0, 2, 1, 3).reshape(M * T, P, 2)
    truth = truth.reshape(M * T, 2)
    nll, inside = np.empty(M * T), np.empty(M * T, dtype=bool)
    rng = np.random.default_rng(seed)
    for start in range(0, M * T, CHUNK):
        part = slice(start, start + CHUNK)
        h = bandwidth(means[part])
        log_truth = log_density(means[part], h, truth[part, None])[:, 0]
        nll[part] = -np.maximum(log_truth, LOG_DENSITY_FLOOR)
        draws = draw(means[part], h, rng)
        threshold = np.quantile(log_density(means[part], h, draws), 1 - HDR_MASS, axis=1)
        inside[part] = log_truth >= threshold
    return {"nll": nll.reshape(M, T).mean(axis=1), "coverage": inside.reshape(M, T).mean(axis=1)}


def bandwidth(means) -> np.ndarray:
    """(B, 2, 2) Scott's bandwidth matrices of B sets of P points (B, P, 2), with the floor."""
    P = means.shape[1]
    centred = means - means.mean(axis=1, keepdims=True)
    cov = np.einsum("bpi,bpj->bij", centred, centred) / max(P - 1, 1)
    return P ** (-1 / 3) * cov + BANDWIDTH_FLOOR**2 * np.eye(2)


def log_density(means, h, points) -> np.ndarray:
    """(B, Q) log of the KDE of centres (B, P, 2), bandwidth (B, 2, 2) at points (B, Q, 2)."""
    det = h[:, 0, 0] * h[:, 1, 1] - h[:, 0, 1] ** 2
    a, b, c = (x[:, None, None] / det[:, None, None] for x in (h[:, 1, 1], -h[:, 0, 1], h[:, 0, 0]))
    dx = points[:, :, None, 0] - means[:, None, :, 0]  # (B, Q, P)
    dy = points[:, :, None, 1] - means[:, None, :, 1]
    exponent = -0.5 * (a * dx * dx + 2 * b * dx * dy + c * dy * dy)
    top = exponent.max(axis=2)
    log_sum = top + np.log(np.exp(exponent - top[..., None]).sum(axis=2))
    norm = np.log(2 * np.pi) + 0.5 * np.log(det) + np.log(means.shape[1])
    return log_sum - norm[:, None]


def draw(means, h, rng) -> np.ndarray:
    """(B, HDR_DRAWS, 2) points drawn from each KDE: a random centre plus N(0, h)."""
    B, P, _ = means.shape
    pick = rng.integers(0, P, (B, HDR_DRAWS))
    noise = np.einsum("bij,bqj->bqi", np.linalg.cholesky(h), rng.standard_normal((B, HDR_DRAWS, 2)))
    return np.take_along_axis(means, pick[..., None], axis=1) + noise
