"""Guidance's modes, each behind one interface (``interface.GuidanceMode``): the fly-by's adjusting burns
(``flyby``), the tracking of a planned trajectory with the chaser's pointing (``tracking``), the synchronized hold
(``sync``), the damping and excitation after the capture (``damping``) and the transport (``transport``). The
rigid-body chaser's accounts of its wheels and thrusters, which the attitude modes share, are ``chaser``'s."""
