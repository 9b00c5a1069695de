"""dcmppi: MPPI, Clustered MPPI, DC-MPPI and Tube-MPPI around static and moving obstacles.

Controllers are pure numpy + scikit-learn; the MuJoCo task suite is `dcmppi.tasks`.
"""

__version__ = "0.1.0"
