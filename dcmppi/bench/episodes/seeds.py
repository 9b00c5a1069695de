"""The seeds of an experiment's environments, shared by experiments and recorded crowds."""

import numpy as np


def environment_seed(base_seed: int, index: int) -> int:
    """The seed of environment `index` of an experiment of `base_seed` (its world, noise and
    controller streams come from it): SeedSequence([base_seed, index])'s first word."""
    return int(np.random.SeedSequence([base_seed, index]).generate_state(1)[0])
