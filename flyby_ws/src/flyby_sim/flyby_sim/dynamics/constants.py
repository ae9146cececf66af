"""Physical constants, each defined once (SI units, unit in the name)."""

MU_EARTH_M3_S2 = 3.986004418e14  # EGM-96 / WGS-84 gravitational parameter
EARTH_RADIUS_M = 6378137.0  # WGS-84 equatorial radius (orbit radius = EARTH_RADIUS_M + altitude)
STANDARD_GRAVITY_M_S2 = 9.80665  # g0 of the rocket equation (Isp g0 = exhaust velocity)
