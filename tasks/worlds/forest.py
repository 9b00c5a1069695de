"""`forest`: the static random forest (paper Table I; docs/design.md)."""

from dcmppi.control.validation import positive

from ..navigation import Navigation
from . import paper


class Forest(Navigation):
    """75 x 50 m map of cylinder clusters; random start and goal >= 30 m apart.

    `n_clusters` is the density: each cluster is 1-4 overlapping cylinders of radii 0.4-1.6 m
    (see `paper.forest_obstacles`). The observation has n_clusters * 4 static rows.
    """

    def __init__(self, n_clusters=paper.FOREST_CLUSTERS, **kwargs):
        n_clusters = positive("n_clusters", n_clusters, integer=True)
        super().__init__(**kwargs)
        self.n_clusters = n_clusters
        self.num_static = n_clusters * paper.FOREST_CYLINDERS_PER_CLUSTER

    def generate_world(self, random):
        return paper.generate_forest(random, self.n_clusters, self.robot_radius)
