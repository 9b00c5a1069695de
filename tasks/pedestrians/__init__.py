"""Pedestrians who walk to goals, their worlds and their tasks.

    walkers.py  the walkers' behaviours by name (social force, ORCA, HRVO, HL) and
                `Pedestrians`, their motion every control period
    worlds.py   the corridor's and the square's worlds as plain numpy, and walls
    base.py     `PedestrianNavigation`: the task whose moving obstacles may walk
    corridor.py the task `corridor` (DRA-MPPI's scene)
    square.py   the task `square` (C-Uniform's scene)
    crowd.py    the task `crowd`: the paper's Dubins cylinders, or walkers
    crowdnav.py the task `crowdnav` (CrowdNav's circle and square crossings) and its world
    crowdnav_plus.py  the task `crowdnav_plus` (CrowdNav++'s scene) and its world

The physics (tasks.physics) moves the walkers; the worlds build on tasks.worlds.
"""
