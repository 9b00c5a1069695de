"""A step's samples rolled out (Controller.perturbed_rollouts): the arrays that the seams
controls(), evaluate() and importance() fill."""

import dataclasses

import numpy as np

from dcmppi.control.kernels.perturbations import Draw


@dataclasses.dataclass(frozen=True, slots=True)
class Rollouts:
    """A step's K perturbed samples rolled out from S start states, and their costs
    (Controller.perturbed_rollouts); the seams controls(), evaluate() and importance() fill the
    arrays in place, a range of samples at a time.

      U0: (N, nu) the warm start that the samples perturb.
      eps: (N, nu, K) the perturbations, or a Draw of them (Controller.sample).
      u: (N, nu, K) the bounded controls project(U0 + eps).
      e: (N, nu, K) the perturbations that remain, u - U0 (the update's and the importance
        term's).
      products: (nu, K) sum_i U0[i, c] e[i, c], the importance term's sums over the steps.
      sums: (nu, K) the horizon sums of e (the clustering features), or None: not asked.
      states: (3, N + 1, S K) the rollouts; columns s K .. s K + K - 1 start from start s.
      J: (S K,) their costs under the step's objective.
      moving: (S K,) J's moving-obstacle term, or None: the step has no moving obstacles.
      importance: (K,) the importance term gamma lambda sum_i u_i^T Sigma^-1 e_i.
    """

    U0: np.ndarray | None = None
    eps: np.ndarray | Draw | None = None
    u: np.ndarray | None = None
    e: np.ndarray | None = None
    products: np.ndarray | None = None
    sums: np.ndarray | None = None
    states: np.ndarray | None = None
    J: np.ndarray | None = None
    moving: np.ndarray | None = None
    importance: np.ndarray | None = None

    @classmethod
    def allocate(cls, U0, eps, x0, starts=1, sums=False, moving=False):
        """Empty Rollouts of the perturbations eps (N, nu, K) (an array or a Draw) of U0
        (N, nu) from x0 ((3,), or (3, S) with starts = S > 1), with the arrays that the seams
        fill; sums, moving: whether to keep those too."""
        n, nu, k = eps.shape
        return cls(
            U0, eps, np.empty((n, nu, k)), np.empty((n, nu, k)), np.zeros((nu, k)),
            np.zeros((nu, k)) if sums else None, start_states(x0, n, starts, k),
            np.empty(starts * k), np.empty(starts * k) if moving else None, np.empty(k),
        )  # fmt: skip

    @property
    def K(self):  # noqa: N802 (the paper's name)
        """The number of samples."""
        return self.u.shape[2]

    def spans(self, cols):
        """The columns (c0, c1) of states, J and moving that hold the samples cols = (j0, j1):
        one range per start state (one for all when cols are all the samples)."""
        k, total = self.K, len(self.J)
        if cols == (0, k):
            return ((0, total),)
        return tuple((c + cols[0], c + cols[1]) for c in range(0, total, k))


def start_states(x0, n, starts, k):
    """Rollout states (3, n + 1, starts k), empty but for the start states: x0 (3,), (3, k) or
    (3, starts) (columns s k .. s k + k - 1 start from x0[:, s])."""
    states = np.empty((3, n + 1, starts * k))
    states.reshape(3, n + 1, starts, k)[:, 0] = np.reshape(x0, (3, starts, -1))
    return states
