"""Exact arcs: the Dubins and unicycle agents' rollouts and the moving obstacles' futures.

The plant holds each command for one control period dt, so the models integrate exactly over
that period with the speed v and turn rate omega held constant (a circular arc):

    a = omega dt / 2
    x += v dt sinc(a) cos(theta + a),   y += v dt sinc(a) sin(theta + a),   theta += 2 a

with sinc(a) = sin(a) / a. Rollouts are time-major internally, (N + 1, 3, K): row i holds x, y and
theta of all K rollouts at step i. The running sums over the horizon are one numba loop per
step that vectorises: each heading's cosine and sine are turned from step to step by the
arc's (cos a, sin a), from dcmppi.control.kernels.libm's sincos of the start headings
(docs/performance.md).
"""

import numba
import numpy as np

from dcmppi.control.kernels.libm import sincos

_SINC_SERIES_MAX = 0.1  # |a| below which sinc(a) uses its series (error < 1e-13)
# the series' last coefficients as products: a division per state-step costs more than the rest
# of the series
_INV_5040, _INV_40320, _INV_362880 = 1.0 / 5040.0, 1.0 / 40320.0, 1.0 / 362880.0


def wrap_angle(theta):
    """Wrap angles to [-pi, pi)."""
    theta = np.asarray(theta, dtype=float)
    return _wrap(theta) if theta.ndim else np.float64(_wrap(float(theta)))


@numba.njit(cache=True)
def _wrap(theta):
    """wrap_angle for arrays or scalars (numpy's remainder semantics, the same values)."""
    return (theta + np.pi) % (2.0 * np.pi) - np.pi


def sinc(a):
    """sin(a) / a, elementwise, exact at 0."""
    a = np.asarray(a, dtype=float)
    if a.size and np.max(np.abs(a)) < _SINC_SERIES_MAX:
        return _sinc_series(a)
    return np.sinc(a / np.pi)


@numba.njit(cache=True)
def _sinc_series(a):
    """sinc's Taylor series to a^6 (one pass, for arrays or scalars)."""
    a2 = a * a
    return 1.0 + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 - a2 * _INV_5040))


def dubins_step(state, omega, v, dt):
    """One exact control period of the Dubins model.

    Args:
      state: (..., 3) x, y, theta.
      omega: (...) turn rate held over the period.
      v: forward speed [m/s]; dt: control period [s].
    Returns:
      (..., 3) the next state (theta not wrapped).
    """
    state = np.asarray(state, dtype=float)
    if state.shape == (3,) and np.ndim(omega) == 0:  # one state: the same operations on scalars
        a = 0.5 * float(omega) * dt
        step = v * dt * (_sinc_series(a) if abs(a) < _SINC_SERIES_MAX else np.sinc(a / np.pi))
        heading = state[2] + a
        x, y = state[0] + step * np.cos(heading), state[1] + step * np.sin(heading)
        return np.array([x, y, state[2] + 2.0 * a])
    a = 0.5 * np.asarray(omega, dtype=float) * dt
    step = v * dt * sinc(a)
    heading = state[..., 2] + a
    return np.stack(
        [
            state[..., 0] + step * np.cos(heading),
            state[..., 1] + step * np.sin(heading),
            state[..., 2] + 2.0 * a,
        ],
        axis=-1,
    )


def rollout_time_major(x0, omega, v, dt, starts=1):
    """Batched exact arc rollouts (Dubins and unicycle), time-major.

    Args:
      x0: (3,) common initial state, (3, K) one per rollout, or with starts = S > 1, (3, S):
        S initial states that all take the same K control sequences (Tube-MPPI's nominal and
        real states); the heading increments and sinc terms are then computed once.
      omega: (N, K) turn rates, already within the control bound.
      v: forward speed, a number (Dubins) or (N, K) per period (unicycle) [m/s].
      dt: control period [s].
    Returns:
      (3, N + 1, S K) states, state-major: [0, i] = x, [1, i] = y, [2, i] = theta at step i
      (x_0 .. x_N), so x and y are contiguous (N + 1, S K) arrays for the cost kernels; columns
      s K .. (s + 1) K - 1 start from x0[:, s].
    """
    if np.ndim(v) == 0:
        return arc_rollout(x0, omega[:, None], dt, v, starts)
    return arc_rollout(x0, np.stack([v, omega], axis=1), dt, None, starts)


def arc_rollout(x0, u, dt, v=None, starts=1):
    """rollout_time_major on the agents' control arrays, read in place.

    u: (N, 1, K) turn rates with the one speed v, or (N, 2, K) speeds and turn rates (v None).
    """
    n, _, k = u.shape
    out = np.empty((3, n + 1, starts, k))
    out[:, 0] = np.reshape(x0, (3, starts, -1))
    arc_columns(out, u, dt, v)
    return out.reshape(3, n + 1, starts * k)


def arc_columns(out, u, dt, v, cols=None):
    """arc_rollout of the samples cols = (j0, j1) (None: all) into their columns of out
    (3, N + 1, S, K), whose start states out[:, 0] are set."""
    j0, j1 = cols or (0, u.shape[2])
    _arcs(out, u, 0.5 * dt, dt if v is None else v * dt, j0, j1)


@numba.njit(inline="always")
def _sin_cos_small(a):
    """(sin a, cos a) for |a| < _SINC_SERIES_MAX by their Taylor series (to a^9 and a^8: the
    first terms left out are below 3e-17 relative)."""
    a2 = a * a
    sin = a * (1.0 + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 + a2 * (-_INV_5040 + a2 * _INV_362880))))
    cos = 1.0 + a2 * (-0.5 + a2 * (1.0 / 24.0 + a2 * (-1.0 / 720.0 + a2 * _INV_40320)))
    return sin, cos


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _arcs(out, u, half_dt, vdt, j0, j1):
    """The arcs of the samples j0:j1, one pass per step: wraps their start headings out[2, 0]
    to [-pi, pi), then x_{i+1} = x_i + chord_i cos(theta_i + a_i), y likewise and theta_{i+1} =
    theta_i + 2 a_i with a_i = omega_i dt / 2 and chord_i = v dt sinc(a_i) (sinc's series below
    _SINC_SERIES_MAX, sin(a) / a above, per arc; per-period speeds: (dt sinc(a)) v).
    The heading's cosine and sine are carried from step to step by rotations: those of theta_0
    (dcmppi.control.kernels.libm's sincos), then of theta_i + a_i and theta_i + 2 a_i, turning by
    (cos a_i, sin a_i) (their series below _SINC_SERIES_MAX, libm's sincos above): a few
    products per step where a full sine and cosine would reduce the angle and evaluate two
    polynomials; the positions stay within 2e-13 m of the closed form over 400 steps (a test).
    The loops vectorise.
    out: (3, n + 1, S, K); u: (n, 1, K) turn rates (one speed: vdt = v dt) or (n, 2, K)
    speeds and turn rates (vdt = dt)."""
    n, starts, k = u.shape[0], out.shape[2], j1 - j0
    turn = u.shape[1] - 1  # the turn rate's column; a speed's is 0 when there are two
    cos, sin = np.empty((starts, k)), np.empty((starts, k))  # of each sample's heading
    for s in range(starts):
        first, c, sn = out[2, 0, s, j0:j1], cos[s], sin[s]
        for j in range(k):
            first[j] = _wrap(first[j])
            sn[j], c[j] = sincos(first[j])
    a, chord, sa, ca = np.empty(k), np.empty(k), np.empty(k), np.empty(k)  # one step's, reused
    for i in range(n):
        omega = u[i, turn, j0:j1]
        beyond = 0  # arcs too sharp for the series (a count, not a flag: the loop vectorises)
        for j in range(k):
            aj = omega[j] * half_dt
            a[j] = aj
            chord[j] = vdt * _sinc_series(aj)
            sa[j], ca[j] = _sin_cos_small(aj)
            beyond += abs(aj) >= _SINC_SERIES_MAX
        if beyond:
            for j in range(k):
                if abs(a[j]) >= _SINC_SERIES_MAX:
                    sa[j], ca[j] = sincos(a[j])
                    chord[j] = vdt * (sa[j] / a[j])
        if turn:
            speed = u[i, 0, j0:j1]
            for j in range(k):
                chord[j] *= speed[j]
        for s in range(starts):
            now, nxt = out[2, i, s, j0:j1], out[2, i + 1, s, j0:j1]
            x0, x1 = out[0, i, s, j0:j1], out[0, i + 1, s, j0:j1]
            y0, y1 = out[1, i, s, j0:j1], out[1, i + 1, s, j0:j1]
            c, sn = cos[s], sin[s]
            for j in range(k):
                nxt[j] = now[j] + (a[j] + a[j])
                ch = c[j] * ca[j] - sn[j] * sa[j]  # theta_i + a_i
                sh = sn[j] * ca[j] + c[j] * sa[j]
                x1[j] = x0[j] + chord[j] * ch
                y1[j] = y0[j] + chord[j] * sh
                c[j] = ch * ca[j] - sh * sa[j]  # theta_i + 2 a_i
                sn[j] = sh * ca[j] + ch * sa[j]


def rollout(state, U, v, dt):
    """Batched exact rollouts of control sequences.

    Args:
      state: (3,) initial x, y, theta.
      U: (K, N) or (N,) turn rates, already within the control bound.
    Returns:
      (K, N + 1, 3) states x_0 .. x_N (a view of the time-major array), or (N + 1, 3) for 1-D U.
    """
    U = np.asarray(U, dtype=float)
    states = rollout_time_major(state, np.atleast_2d(U).T, v, dt).transpose(2, 1, 0)
    return states[0] if U.ndim == 1 else states


def obstacle_futures(obstacles, speed, turn_rate, n, dt):
    """Positions of moving obstacles along exact Dubins arcs with constant speed and turn rate.

    Args:
      obstacles: (L, >=3) current x, y, heading (further columns ignored).
      speed, turn_rate: (L, P) one constant speed [m/s] and turn rate [rad/s] per sampled future.
      n: horizon steps; dt: control period.
    Returns:
      (L, P, n + 1, 2) positions at t_i = i dt, i = 0..n.
    """
    obstacles = np.asarray(obstacles, dtype=float)
    speed, turn_rate = np.asarray(speed, dtype=float), np.asarray(turn_rate, dtype=float)
    if speed.shape != turn_rate.shape or speed.shape[:1] != obstacles.shape[:1]:
        raise ValueError(
            f"speed and turn_rate must be (L, P) for {len(obstacles)} obstacles; got "
            f"{speed.shape} and {turn_rate.shape}"
        )
    return _futures(np.ascontiguousarray(obstacles[:, :3]), speed, turn_rate, int(n), float(dt))


_ARC_RECURRENCE_MIN = 1e-3  # |omega dt / 2| from which sin(half) comes from the recurrence


@numba.njit(cache=True)
def _futures(pose, speed, turn, n, dt):
    """obstacle_futures: at t_i the arc's chord is v t_i sinc(h_i) along the heading theta + h_i,
    h_i = omega t_i / 2 = i a. The unit vectors of i a come from the rotation recurrence
    r_{i+1} = r_i exp(j a) (one complex product per step instead of three transcendental calls;
    rounding grows by about one ulp per step), and v t_i sinc(h_i) = v sin(i a) / (omega / 2) for
    |a| >= 1e-3, sinc's series below."""
    L, P = speed.shape
    out = np.empty((L, P, n + 1, 2))
    for l in range(L):
        x0, y0 = pose[l, 0], pose[l, 1]
        c0, s0 = np.cos(pose[l, 2]), np.sin(pose[l, 2])
        for p in range(P):
            v, w = speed[l, p], turn[l, p]
            a = 0.5 * w * dt
            ca, sa = np.cos(a), np.sin(a)
            series = abs(a) < _ARC_RECURRENCE_MIN
            zr, zi = 1.0, 0.0  # cos(i a), sin(i a)
            for i in range(n + 1):
                if series:
                    d = v * (i * dt) * _sinc_series(i * a)
                else:
                    d = v * zi / (0.5 * w)
                out[l, p, i, 0] = x0 + d * (c0 * zr - s0 * zi)
                out[l, p, i, 1] = y0 + d * (s0 * zr + c0 * zi)
                zr, zi = zr * ca - zi * sa, zr * sa + zi * ca
    return out
