"""The worlds as plain numpy and the tasks of static and Dubins obstacles.

    base.py        one episode's `World`: the contract, its map, clearance, impossible worlds
    sampling.py    starts, goals and non-overlapping discs
    paper.py       the paper's worlds: the static forest and the moving crowd
    arcs.py        the crowd's Dubins motion (`DubinsObstacles`), exact arcs off the walls
    forest.py      the task `forest` (paper Table I)
    two_valley.py  the tasks `blocked` and `crossing`: one obstacle on the straight line
    layout.py      the task `layout`: cylinders, start and goal from a file or a BARN world
    barn.py        BARN's navigation score and its shortest collision-free path length

Nothing here imports the tasks' other subpackages; pedestrians and replay build on it.
"""
