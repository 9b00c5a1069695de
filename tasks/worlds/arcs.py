"""Moving obstacles on Dubins arcs: the crowd's motion (the "constant" behaviour)."""

import math

import numpy as np

from dcmppi.control.kernels.dynamics import wrap_angle


def dubins_pose(pose, speed, turn_rate, t) -> np.ndarray:
    """Closed-form Dubins arcs (no boundary): poses (..., 3) after time t from pose (..., 3)."""
    x, y, theta = np.moveaxis(np.asarray(pose, dtype=np.float64), -1, 0)
    dtheta = np.asarray(turn_rate) * t
    chord = np.asarray(speed) * t * np.sinc(dtheta / (2.0 * np.pi))
    mid = theta + 0.5 * dtheta
    return np.stack([x + chord * np.cos(mid), y + chord * np.sin(mid), theta + dtheta], axis=-1)


class DubinsObstacles:
    """Cylinders moving with constant speed and turn rate, reflecting off the map boundary.

    Each substep of length h moves an obstacle along the exact arc; a centre that leaves the
    bounds is mirrored back and its heading reflected (x wall: theta -> pi - theta, y wall:
    theta -> -theta), so centres always stay inside the map.
    """

    def __init__(self, pose, speed, turn_rate, bounds, h):
        """pose (L, 3) x, y, heading; speed, turn_rate (L,); bounds (4,); h substep [s]."""
        self.z = pose[:, 0] + 1j * pose[:, 1]
        self.theta = np.array(pose[:, 2], dtype=np.float64)
        self._speed = np.asarray(speed, dtype=np.float64)
        self._bounds = np.asarray(bounds, dtype=np.float64)
        self._dtheta = np.asarray(turn_rate, dtype=np.float64) * h
        self._chord = np.asarray(speed, dtype=np.float64) * h * np.sinc(self._dtheta / (2 * np.pi))
        self._half = 0.5 * self._dtheta
        self._steps = None

    def pose(self) -> np.ndarray:
        """Current poses (L, 3) x, y, heading (wrapped to [-pi, pi))."""
        return np.column_stack([self.z.real, self.z.imag, wrap_angle(self.theta)])

    @property
    def velocity(self) -> np.ndarray:
        """World-frame velocities (L, 2) now: speed x (cos, sin) of the heading."""
        return self._speed[:, None] * np.column_stack([np.cos(self.theta), np.sin(self.theta)])

    def advance(self, n) -> np.ndarray:
        """Moves n substeps; returns the centres after each substep as complex (n, L)."""
        if self._steps is None or len(self._steps) != n:
            # Chord k of each arc, relative to the heading at the window start.
            k = np.arange(n)[:, None] + 0.5
            self._steps = self._chord * np.exp(1j * k * self._dtheta)
        z = self.z + np.cumsum(self._steps * np.exp(1j * self.theta), axis=0)
        theta = self.theta + n * self._dtheta
        xmin, ymin, xmax, ymax = self._bounds
        x, y = z.real, z.imag
        out = (x < xmin) | (x > xmax) | (y < ymin) | (y > ymax)
        if out.any():
            idx = np.flatnonzero(out.any(axis=0))
            z[:, idx], theta[idx] = self._advance_reflecting(idx, n)
        self.z = z[-1].copy()
        self.theta = wrap_angle(theta)
        return z

    def _advance_reflecting(self, idx, n):
        """Substep-by-substep motion with reflections for the (few) obstacles idx."""
        xmin, ymin, xmax, ymax = self._bounds
        z = np.empty((n, len(idx)), dtype=np.complex128)
        theta_end = np.empty(len(idx))
        for j, i in enumerate(idx):
            x, y, theta = self.z[i].real, self.z[i].imag, self.theta[i]
            chord, half, dtheta = self._chord[i], self._half[i], self._dtheta[i]
            for k in range(n):
                x += chord * math.cos(theta + half)
                y += chord * math.sin(theta + half)
                theta += dtheta
                if not xmin <= x <= xmax:
                    x = 2.0 * (xmin if x < xmin else xmax) - x
                    theta = math.pi - theta
                if not ymin <= y <= ymax:
                    y = 2.0 * (ymin if y < ymin else ymax) - y
                    theta = -theta
                z[k, j] = complex(x, y)
            theta_end[j] = theta
        return z, theta_end
