"""flyby_msgs_py: the interface contract in code."""
