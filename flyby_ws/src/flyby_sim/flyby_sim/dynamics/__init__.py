"""Shared physics of every flyby package, without ROS (DESIGN §10).

Rotations (``rotation``), relative orbital motion and the Clohessy-Wiltshire transition and coast
(``orbital``), rigid-body attitude (``attitude``), box geometry and clearance (``geometry``),
rocket equation and thruster limits (``propulsion``), physical constants (``constants``) and the
checks of configuration numbers (``checks``). Estimation, planning and guidance take their physics
from here; none of them imports the plant, the sensor models or the simulator node.
"""
