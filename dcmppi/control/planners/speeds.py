"""The update's mean of a norm-bounded velocity (Controller option speed_mean).

- "vector": the paper's U = U0 + sum_k w_k e_k. Its velocity is a weighted mean of samples inside
  the disc |v| <= v_max: samples that spread in direction average to a speed below the top one,
  so a plan that should go straight at full speed cannot reach it.
- "polar": each step's velocity keeps the vector mean's direction, at the weighted mean of the
  samples' speeds sum_k w_k |v_k| (at most v_max: feasible), so samples at the top speed in
  spread directions average to the top speed. Other controls keep the vector mean.
"""

import numpy as np

SPEED_MEANS = ("vector", "polar")


def speed_mean_param(value, agent):
    """One of SPEED_MEANS; "polar" only for an agent with a norm-bounded pair of controls (a
    ValueError names the fix otherwise)."""
    if value not in SPEED_MEANS:
        raise ValueError(f"speed_mean must be one of {SPEED_MEANS}; got {value!r}")
    if value == "polar" and (agent.norm_axes is None or len(agent.norm_axes) != 2):
        raise ValueError(
            f"speed_mean='polar' needs an agent with a norm-bounded velocity (holonomic); "
            f"agent {agent.name!r} has none: use speed_mean='vector'"
        )
    return value


def polar_means(U, u, w, axes, labels=None):
    """U (N, nu) (or (M, N, nu), one per cluster) with each step's velocity, controls `axes`
    (2,), scaled to the weighted mean speed of the samples u (N, nu, K) under weights w (K,)
    (with labels (K,): cluster m's samples, labels == m, each cluster's weights summing to 1).
    A zero velocity stays zero."""
    a, b = axes
    speeds = np.hypot(u[:, a, :], u[:, b, :])  # (N, K)
    single = U.ndim == 2
    U = np.array(U[None] if single else U, dtype=float)
    if labels is None:
        mean = (speeds @ w)[None]  # (1, N)
    else:
        member = labels[None, :] == np.arange(len(U))[:, None]  # (M, K)
        mean = (member * w) @ speeds.T  # (M, N)
    norm = np.hypot(U[..., a], U[..., b])
    scale = np.divide(mean, norm, out=np.zeros_like(norm), where=norm > 0)
    U[..., a] *= scale
    U[..., b] *= scale
    return U[0] if single else U
