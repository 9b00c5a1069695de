"""Projection of perturbed control sequences into an agent's bounds, in one compiled pass.

The planners perturb a reference U0 (N, nu) by eps (N, nu, K) and apply u = project(U0 + eps);
what remains of the perturbation, u - U0, enters the importance term, the update and the
clustering features (so the update stays within the convex bounds). These kernels give the same
values as `Agent.project` for box bounds and for a box and a disc (holonomic).
"""

import numba
import numpy as np

from dcmppi.control.kernels.threads import in_cols, n_cols


def project_columns(agent, U0, eps, u, e, sums, cols=None, products=None):
    """Bounded controls u = project(U0 + eps) and the perturbations that remain, u - U0, of the
    samples cols = (j0, j1) (None: all), written in place into their columns of u, e (N, nu, K);
    sums (nu, K) zeros (or NO_SUMS: none asked) get the horizon sums of u - U0, and products
    (nu, K) zeros, when given, the importance term's sums over the steps, sum_i U0[i, c]
    e[i, c] (dcmppi.control.kernels.sums' values), in the same pass.

    eps: (N, nu, K), or a view with a zero stride along N (one constant perturbation per sample),
    read then as one contiguous (1, nu, K) block.
    """
    if eps.strides[0] == 0:  # constant: one contiguous (1, nu, K) block for every step
        eps = eps[:1]
    products = NO_SUMS if products is None else products
    if agent.norm_axes is None:  # a box: one pass, the same values as np.clip
        _clip_box(U0, eps, agent.lower, agent.upper, sums, products, u, e, cols)
    elif len(agent.norm_axes) == 2:  # box and disc (holonomic): Agent.project's values
        _clip_box_disc(
            U0, eps, agent.lower, agent.upper, *agent.norm_axes, agent.norm_limit, sums, products,
            u, e, cols,
        )  # fmt: skip
    else:
        j0, j1 = cols or (0, eps.shape[2])
        u[:, :, j0:j1] = agent.project(U0[:, :, None] + eps[:, :, j0:j1])
        e[:, :, j0:j1] = u[:, :, j0:j1] - U0[:, :, None]
        if len(sums):
            sums[:, j0:j1] = horizon_sums(np.ascontiguousarray(e[:, :, j0:j1]))
        for i in range(len(U0) if len(products) else 0):  # i in order, as the kernels
            products[:, j0:j1] += U0[i, :, None] * e[i, :, j0:j1]


@numba.njit(inline="always")
def add_row(out_e, u0, c, sums, products, cols):
    """sums[c] += out_e and products[c] += u0 out_e in columns cols, each where it is (nu, K)."""
    if len(sums):
        total = in_cols(sums[c], cols)
        for j in range(len(out_e)):
            total[j] += out_e[j]
    if len(products):
        total = in_cols(products[c], cols)
        for j in range(len(out_e)):
            total[j] += u0 * out_e[j]


@numba.njit(cache=True, nogil=True)
def _clip_box(U0, eps, lower, upper, sums, products, u, e, cols):
    """u = min(max(U0 + eps, lower), upper) and u - U0 in columns cols of u, e (N, nu, K)
    (threads.in_cols), in one pass.

    U0: (N, nu); eps: (N, nu, K), or (1, nu, K): the same perturbation at every step (constant),
    read from one contiguous block; lower, upper: (nu,); sums: (nu, K) zeros that get the
    horizon sums of u - U0 (step by step, in order), or an empty array for none; products
    likewise the sums of U0[i, c] (u - U0)[i, c].
    """
    n, nu = U0.shape
    each = eps.shape[0] > 1
    for i in range(n):
        for c in range(nu):
            u0, lo, hi = U0[i, c], lower[c], upper[c]
            row = in_cols(eps[i if each else 0, c], cols)
            out_u, out_e = in_cols(u[i, c], cols), in_cols(e[i, c], cols)
            for j in range(len(row)):
                v = min(max(u0 + row[j], lo), hi)
                out_u[j] = v
                out_e[j] = v - u0
            add_row(out_e, u0, c, sums, products, cols)


@numba.njit(cache=True, nogil=True)
def _clip_box_disc(U0, eps, lower, upper, p, q, limit, sums, products, u, e, cols):
    """As _clip_box, then controls p and q scaled back onto |(u_p, u_q)| <= limit; one pass,
    the scale selected without a branch (1 inside the disc) so the loop vectorises. The scales
    go through a scratch row: the loop that reads u_p and u_q writes neither (u may be any
    caller's array, so the compiler cannot tell its rows apart)."""
    n, nu = U0.shape
    k = n_cols(u.shape[2], cols)
    each = eps.shape[0] > 1
    scales = np.empty(k)
    for i in range(n):
        for c in range(nu):
            u0, lo, hi = U0[i, c], lower[c], upper[c]
            row, out_u = in_cols(eps[i if each else 0, c], cols), in_cols(u[i, c], cols)
            for j in range(k):
                out_u[j] = min(max(u0 + row[j], lo), hi)
        disc_row(U0, p, q, limit, sums, products, u, e, i, cols, scales)


@numba.njit(inline="always")
def disc_row(U0, p, q, limit, sums, products, u, e, i, cols, scales):
    """Row i of u (N, nu, K), already in the box: controls p and q scaled back onto |(u_p,
    u_q)| <= limit, e = u - U0 and their sums (add_row) in columns cols; scales: a scratch row
    of their width."""
    up, uq = in_cols(u[i, p], cols), in_cols(u[i, q], cols)
    for j in range(len(scales)):
        norm = np.sqrt(up[j] * up[j] + uq[j] * uq[j])
        scales[j] = limit / max(norm, 1e-300) if norm > limit else 1.0
    for c in range(u.shape[1]):
        u0, out_u, out_e = U0[i, c], in_cols(u[i, c], cols), in_cols(e[i, c], cols)
        if c == p or c == q:
            for j in range(len(scales)):
                v = out_u[j] * scales[j]
                out_u[j] = v
                out_e[j] = v - u0
        else:
            for j in range(len(scales)):
                out_e[j] = out_u[j] - u0
        add_row(out_e, u0, c, sums, products, cols)


def bound(agent, u):
    """`agent.project` of one control vector u (nu,), its values, in one compiled call."""
    if agent.norm_axes is None:
        return _bound(u, agent.lower, agent.upper, 0, 0, np.inf)
    if len(agent.norm_axes) == 2:
        return _bound(u, agent.lower, agent.upper, *agent.norm_axes, agent.norm_limit)
    return agent.project(u[None], axis=1)[0]


def bound_rows(agent, u):
    """`agent.project(u, axis=1)` of control rows u (N, nu), their values, in one compiled
    call (`bound` of each row)."""
    if agent.norm_axes is None:
        return _bound_rows(u, agent.lower, agent.upper, 0, 0, np.inf)
    if len(agent.norm_axes) == 2:
        return _bound_rows(u, agent.lower, agent.upper, *agent.norm_axes, agent.norm_limit)
    return agent.project(u, axis=1)


@numba.njit(cache=True)
def _bound_rows(u, lower, upper, p, q, limit):
    out = np.empty_like(u)
    for i in range(u.shape[0]):
        out[i] = _bound(u[i], lower, upper, p, q, limit)
    return out


@numba.njit(cache=True)
def _bound(u, lower, upper, p, q, limit):
    """np.clip(u, lower, upper), then u_p and u_q scaled back onto the disc of radius limit
    (np.inf: none). The clip picks as numpy's does (a bound when equal: signed zeros too)."""
    out = np.empty_like(u)
    for c in range(len(u)):
        x = u[c] if u[c] > lower[c] else lower[c]
        out[c] = x if x < upper[c] else upper[c]
    norm = np.sqrt(out[p] * out[p] + out[q] * out[q])
    if norm > limit:
        scale = limit / max(norm, 1e-300)
        out[p] *= scale
        out[q] *= scale
    return out


NO_SUMS = np.zeros((0, 0))  # the clip kernels' `sums` when none are asked for


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
