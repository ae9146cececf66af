"""flyby_guidance: guidance: the fly-by's terminal approach and trajectory adjusting, tracking of a planned trajectory,
the synchronized hold, attitude guidance, damping and transport control, and GuidanceCore with its node."""
