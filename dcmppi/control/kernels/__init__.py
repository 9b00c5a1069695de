"""Compiled numerics: the bottom layer of dcmppi.control.

    dynamics.py      exact arcs: the agents' rollouts and the moving obstacles' futures
    costs.py         the static cost map and the DC-MPPI collision term (paper Eq. 30-31)
    perturbations.py counter-based standard normals drawn (and bounded) in one pass
    projection.py    perturbed controls projected into an agent's box (and disc)
    normal.py        numpy's Generator.standard_normal, bit for bit, compiled
    sums.py          the planners' sums over samples and steps, in numpy's pairwise order
    dbscan.py        scikit-learn's DBSCAN labels for the points of one step
    social.py        Helbing & Molnar's social force (pedestrians and the `social` predictor)
    libm.py          sin, cos, log for vectorised loops; threads.py: a step's samples split
    _malloc.py       glibc's heap kept between steps

numpy, numba and scipy only; of dcmppi, only dcmppi.control's defaults, validation and
registry (tests/test_architecture.py).
"""
