"""MJCF models of the arena and the obstacles (package data; robots/: one file per robot).

Data only: no Python imports. Installed as dcmppi.models (pyproject.toml, package-dir); the
tasks load these files with importlib.resources.
"""
