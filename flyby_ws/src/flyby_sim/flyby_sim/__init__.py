"""flyby_sim: the plant simulator (truth, thrusters, sensors, /clock)."""
