"""The field's classical planners as controllers, beside the MPPI family:

    base.py          Classical: the robot, the observation, the velocity they track
    reciprocal.py    orca, hrvo, hl: navground's behaviours (holonomic, unicycle)
    social_force.py  social_force: the project's social-force kernel towards the goal
    dwa.py           dwa: a dynamic window with nav2 DWB's critics (every agent)

Each plans one command per control step from the observation every controller gets; importing
this package registers them (the controllers' registry does on first use).
"""

from dcmppi.control.planners.classical import dwa, reciprocal, social_force
from dcmppi.control.planners.classical.base import Classical

__all__ = ["Classical", "dwa", "reciprocal", "social_force"]
