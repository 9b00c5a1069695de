"""MJCF models of the robot, the obstacles and the arenas (package data)."""
