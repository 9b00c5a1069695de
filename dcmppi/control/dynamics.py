"""Exact arcs: the Dubins and unicycle agents' rollouts and the moving obstacles' futures.

The plant holds each command for one control period dt, so the models integrate exactly over
that period with the speed v and turn rate omega held constant (a circular arc):

    a = omega dt / 2
    x += v dt sinc(a) cos(theta + a),   y += v dt sinc(a) sin(theta + a),   theta += 2 a

with sinc(a) = sin(a) / a. Rollouts are time-major internally, (N + 1, 3, K): row i holds x, y and
theta of all K rollouts at step i. The running sums over the horizon are two small numba loops
(a numpy version needs a call per step, or per step and column set); the cosine and sine of the
headings are numpy's, taken in float32 (docs/performance.md). The positions stay float64 and are
accurate to about 1e-6 m over a 5 s horizon, far below the 0.1 m cost-map resolution.
"""

import numba
import numpy as np

from .threads import in_cols, n_cols

_SINC_SERIES_MAX = 0.1  # |a| below which sinc(a) uses its series (error < 1e-13)


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
    return 1.0 + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 - a2 / 5040.0))


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


def arc_columns(out, u, dt, v, cols=None, sharp=False):
    """arc_rollout of the samples cols = (j0, j1) (None: all) into their columns of out
    (3, N + 1, S, K), whose start states out[:, 0] are set.

    The chords come from sinc's series unless some arc of these columns is beyond it, or
    sharp=True (another part's arc is: a batch split over threads keeps the whole batch's
    choice). Returns whether some arc of these columns is beyond the series.
    """
    vdt = dt if v is None else v * dt
    a, mid, step = _arcs(out, u, 0.5 * dt, vdt, cols)
    beyond = step is None
    if beyond or sharp:  # a sharp turn: sinc beyond its series
        step = vdt * np.sinc(a / np.pi)
        if v is None:
            step *= u[:, 0] if cols is None else u[:, 0, cols[0] : cols[1]]
    _positions(out, step, np.cos(mid), np.sin(mid), cols)
    return beyond


@numba.njit(cache=True, nogil=True)
def _arcs(out, u, half_dt, vdt, cols):
    """The arcs of every period of the samples cols (threads.in_cols): wraps their start
    headings out[2, 0] to [-pi, pi) and writes theta_{i+1} = theta_i + 2 a_i into out[2].
    out: (3, n + 1, S, K); u: (n, 1, K) turn rates (one speed: vdt = v dt) or (n, 2, K)
    speeds and turn rates (vdt = dt).
    Returns a = omega dt / 2 (n, k), the mid-period headings float32(theta_i + a_i) (n, S, k),
    and the chords v dt sinc(a) (n, k) (per-period speeds: (dt sinc(a)) v), or None when some
    |a| is beyond sinc's series; k samples. One pass per step over the samples (no
    temporaries)."""
    n, starts, k = u.shape[0], out.shape[2], n_cols(u.shape[2], cols)
    turn = u.shape[1] - 1  # the turn rate's column; a speed's is 0 when there are two
    for s in range(starts):
        first = in_cols(out[2, 0, s], cols)
        for j in range(k):
            first[j] = _wrap(first[j])
    a = np.empty((n, k))
    chord = np.empty((n, k))
    mid = np.empty((n, starts, k), dtype=np.float32)
    beyond = 0  # arcs too sharp for the series (a count, not a max: the loop vectorises)
    for i in range(n):
        ai_row, c_row, omega = a[i], chord[i], in_cols(u[i, turn], cols)
        for j in range(k):
            ai = omega[j] * half_dt
            ai_row[j] = ai
            a2 = ai * ai
            c_row[j] = vdt * (1.0 + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 - a2 / 5040.0)))
            beyond += abs(ai) >= _SINC_SERIES_MAX
        if turn:
            speed = in_cols(u[i, 0], cols)
            for j in range(k):
                c_row[j] *= speed[j]
        for s in range(starts):
            now, nxt = in_cols(out[2, i, s], cols), in_cols(out[2, i + 1, s], cols)
            m = mid[i, s]
            for j in range(k):
                m[j] = np.float32(now[j] + ai_row[j])
                nxt[j] = now[j] + (ai_row[j] + ai_row[j])
    if beyond:
        return a, mid, None
    return a, mid, chord


@numba.njit(cache=True, nogil=True)
def _positions(out, step, cos, sin, cols):
    """x_{i+1} = x_i + step_i cos_i and y likewise into out[:2] (from out[:2, 0]), columns
    cols (threads.in_cols).
    out: (3, n + 1, S, K); step: (n, k) arc lengths' chords; cos, sin: (n, S, k) float32."""
    n, starts, k = step.shape[0], out.shape[2], step.shape[1]
    for i in range(n):
        for s in range(starts):
            x0, x1 = in_cols(out[0, i, s], cols), in_cols(out[0, i + 1, s], cols)
            y0, y1 = in_cols(out[1, i, s], cols), in_cols(out[1, i + 1, s], cols)
            c, sn, d = cos[i, s], sin[i, s], step[i]
            for j in range(k):
                x1[j] = x0[j] + d[j] * np.float64(c[j])
                y1[j] = y0[j] + d[j] * np.float64(sn[j])


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
