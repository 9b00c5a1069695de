"""MJCF files of the robots, one per agent kind (dubins.xml, unicycle.xml, holonomic.xml): data
only, loaded by tasks/physics.py."""
