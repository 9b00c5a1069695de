"""The perturbations of a step's K samples (Controller.sample): eps (N, nu, K) from N(0, Sigma),
time-major, of one of the PERTURBATIONS kinds, drawn from the episode's own stream
(dcmppi.control.kernels.perturbations).

- constant: one draw per sample and control, the same at every step (paper Sec. IV-A);
- time_varying: independent draws per step;
- mixed: the sum of one constant and one time-varying draw, each N(0, Sigma / 2);
- correlated: each sample's steps an AR(1) sequence eps_i = a eps_{i-1} + sqrt(1 - a^2) w_i,
  w_i ~ N(0, Sigma), of correlation a in [0, 1) (between time_varying at a = 0 and constant at
  a = 1).
Every kind has the per-step variance Sigma that the importance term assumes.
"""

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.kernels.perturbations import Draw, draw_normals
from dcmppi.control.validation import positive

PERTURBATIONS = ("constant", "time_varying", "mixed", "correlated")


class Sampler:
    """A controller's perturbations: one draw of the stream a step, numbered within the episode.

    Args: agent (its controls and bounds), Sigma (nu,) per-step variances, N steps, K samples,
    perturbation (one of PERTURBATIONS) and its correlation (0 but for "correlated"), threads
    that make a per-step draw at once. Attributes: sigma (nu,) = sqrt(Sigma); raw (nu, K): the
    step's constant draw (constant perturbations), else None.
    """

    def __init__(self, agent, Sigma, N, K, perturbation, correlation, threads):
        self.agent, self.N, self.K, self.threads = agent, N, K, threads
        self.sigma = np.sqrt(Sigma)
        self.perturbation, self.correlation = perturbation, correlation
        self.raw = self._keys = None

    def seed(self, rng):
        """Take the episodes' streams from a child of the np.random.Generator rng (so that rng's
        own draws stay the predictor's)."""
        self._keys = rng.spawn(1)[0]

    def reset(self):
        """Start the next episode's stream."""
        self.key = int(self._keys.integers(2**63))
        self.draws = 0

    def sample(self):
        """This step's perturbations eps (N, nu, K): an array, or a Draw of them that
        Controller.controls() makes in the pass that bounds them, row by row while the row is in
        the cache. The per-step kinds are a Draw for an agent bounded by a box (or a box and a
        disc of two controls), else an array; the constant kind is the same read-only (1, nu, K)
        block at every step."""
        nu, K = self.agent.nu, self.K
        if self.perturbation == "constant":
            raw = self.normals((1, nu, K), self.sigma)
            self.raw = raw[0]
            return constant_steps(raw, self.N)
        self.raw = None  # no constant draw of the whole horizon this step
        scale, add = self.sigma, None
        if self.perturbation == "mixed":
            half = np.sqrt(0.5)  # each draw N(0, Sigma / 2): the sum has variance Sigma each step
            raw = self.normals((1, nu, K), self.sigma)[0]
            scale, add = half * self.sigma, half * raw
        self.draws += 1
        draw = Draw(self.key, self.draws, (self.N, nu, K), scale, add, self.correlation)
        axes = self.agent.norm_axes
        return draw if axes is None or len(axes) == 2 else draw.array(self.threads)

    def normals(self, shape, scale):
        """The next draw of this episode's stream: z * scale[:, None] for standard normals z of
        `shape` (1, nu, K), on this thread."""
        self.draws += 1
        return draw_normals(self.key, self.draws, shape, scale)


def constant_steps(raw, n):
    """np.broadcast_to(raw, (n, nu, K)) of raw (1, nu, K), C-contiguous: the same read-only
    view (a zero stride along the steps), made without numpy's general broadcasting."""
    view = np.ndarray((n, *raw.shape[1:]), raw.dtype, raw, 0, (0, *raw.strides[1:]))
    view.flags.writeable = False
    return view


def perturbation_param(value, agent):
    """One of PERTURBATIONS, the agent's default for None; a ValueError for anything else."""
    value = agent.default_perturbation if value is None else value
    if value not in PERTURBATIONS:
        raise ValueError(f"perturbation must be one of {PERTURBATIONS}; got {value!r}")
    return value


def correlation_param(value, perturbation):
    """The correlation of "correlated" perturbations: value in [0, 1), CORRELATION for None; 0
    for the other kinds, which take none (a ValueError if one is given)."""
    if perturbation != "correlated":
        if value is not None:
            raise ValueError(
                f"correlation applies to perturbation='correlated' only; got perturbation="
                f"{perturbation!r}: drop correlation or set perturbation='correlated'"
            )
        return 0.0
    value = defaults.CORRELATION if value is None else value
    checked = positive("correlation", value, allow_zero=True)
    if checked >= 1.0:
        raise ValueError(
            f"correlation must be in [0, 1) (1 is perturbation='constant'); got {value!r}"
        )
    return checked
