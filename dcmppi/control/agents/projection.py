"""Projection of perturbed control sequences into an agent's bounds, in one compiled pass.

The planners perturb a reference U0 (N, nu) by eps (N, nu, K) and apply u = project(U0 + eps);
what remains of the perturbation, u - U0, enters the importance term, the update and the
clustering features (so the update stays within the convex bounds). These kernels give the same
values as `Agent.project` for box bounds and for a box and a disc (holonomic).
"""

import numba
import numpy as np


def project_perturbed(agent, U0, eps, sums=False):
    """Bounded controls u = project(U0 + eps) (N, nu, K) and the perturbations u - U0 that
    remain; with sums=True also their horizon sums (nu, K), added up in the same pass.

    eps: (N, nu, K), or a view with a zero stride along N (one constant perturbation per sample),
    read then as one contiguous (1, nu, K) block.
    """
    if eps.strides[0] == 0:  # constant: one contiguous (1, nu, K) block for every step
        eps = eps[:1]
    out = np.zeros((agent.nu, eps.shape[2])) if sums else _NO_SUMS
    if agent.norm_axes is None:  # a box: one pass, the same values as np.clip
        u, e = _clip_box(U0, eps, agent.lower, agent.upper, out)
    elif len(agent.norm_axes) == 2:  # box and disc (holonomic): Agent.project's values
        u, e = _clip_box_disc(
            U0, eps, agent.lower, agent.upper, *agent.norm_axes, agent.norm_limit, out
        )
    else:
        u = agent.project(U0[:, :, None] + eps)
        e = u - U0[:, :, None]
        out = horizon_sums(e) if sums else out
    return (u, e, out) if sums else (u, e)


@numba.njit(cache=True)
def _clip_box(U0, eps, lower, upper, sums):
    """u = min(max(U0 + eps, lower), upper) and u - U0, both (N, nu, K), in one pass.

    U0: (N, nu); eps: (N, nu, K), or (1, nu, K): the same perturbation at every step (constant),
    read from one contiguous block; lower, upper: (nu,); sums: (nu, K) zeros that get the
    horizon sums of u - U0 (step by step, in order), or an empty array for none.
    """
    n, nu = U0.shape
    k = eps.shape[2]
    each, add = eps.shape[0] > 1, len(sums) > 0
    u = np.empty((n, nu, k))
    e = np.empty((n, nu, k))
    for i in range(n):
        for c in range(nu):
            u0, lo, hi = U0[i, c], lower[c], upper[c]
            row, out_u, out_e = eps[i if each else 0, c], u[i, c], e[i, c]
            for j in range(k):
                v = min(max(u0 + row[j], lo), hi)
                out_u[j] = v
                out_e[j] = v - u0
            if add:
                total = sums[c]
                for j in range(k):
                    total[j] += out_e[j]
    return u, e


@numba.njit(cache=True)
def _clip_box_disc(U0, eps, lower, upper, p, q, limit, sums):
    """As _clip_box, then controls p and q scaled back onto |(u_p, u_q)| <= limit; one pass,
    the scale selected without a branch (1 inside the disc) so the loop vectorises."""
    n, nu = U0.shape
    k = eps.shape[2]
    each, add = eps.shape[0] > 1, len(sums) > 0
    u = np.empty((n, nu, k))
    e = np.empty((n, nu, k))
    for i in range(n):
        for c in range(nu):
            u0, lo, hi = U0[i, c], lower[c], upper[c]
            row, out_u = eps[i if each else 0, c], u[i, c]
            for j in range(k):
                out_u[j] = min(max(u0 + row[j], lo), hi)
        up, uq = u[i, p], u[i, q]
        for j in range(k):
            norm = np.sqrt(up[j] * up[j] + uq[j] * uq[j])
            scale = limit / max(norm, 1e-300) if norm > limit else 1.0
            up[j] *= scale
            uq[j] *= scale
        for c in range(nu):
            u0, out_u, out_e = U0[i, c], u[i, c], e[i, c]
            for j in range(k):
                out_e[j] = out_u[j] - u0
            if add:
                total = sums[c]
                for j in range(k):
                    total[j] += out_e[j]
    return u, e


_NO_SUMS = np.zeros((0, 0))  # the clip kernels' `sums` when none are asked for


@numba.njit(cache=True)
def horizon_sums(eps):
    """(nu, K) sums of eps (N, nu, K) over the horizon, step by step in order (the values the
    clip kernels add up)."""
    n, nu, k = eps.shape
    sums = np.zeros((nu, k))
    for i in range(n):
        for c in range(nu):
            row, total = eps[i, c], sums[c]
            for j in range(k):
                total[j] += row[j]
    return sums
