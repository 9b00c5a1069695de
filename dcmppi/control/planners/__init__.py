"""The planners: the top layer of dcmppi.control.

    controller.py    Controller: parameters, one step's frame, projection, rollouts, costs
    sampling.py      the perturbations of a step's samples (Sampler)
    rollouts.py      a step's samples rolled out (Rollouts)
    observations.py  the checks of what act() observes
    mppi.py          baseline MPPI (paper Alg. 1) and its update (speed_mean)
    clustered.py     Clustered MPPI (Alg. 2): DBSCAN over the rollouts, Alg. 1 per cluster
    dc.py            DC-MPPI (Alg. 3): Clustered MPPI with sampled obstacle futures
    tube.py          Tube-MPPI (Williams et al. 2018)
    temperature.py   lambda_="auto": the temperature chosen each step
    smoothing.py     the plan's filter, hysteresis in the choice of cluster (preset "smooth")
    diagnostics.py   what a step leaves for plots, videos and the bench
    shield.py        the safety shield of the applied command, after any planner (option shield)
    velocities.py    the obstacles' velocities and a velocity tracked, for classical and shield
    registry.py      the controllers by name (built-ins load on first use)
    classical/       the field's classical planners (orca, hrvo, hl, social_force, dwa)

May import anything of dcmppi.control; nothing below it imports a planner.
"""
