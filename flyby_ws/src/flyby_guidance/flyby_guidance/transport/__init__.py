"""Guidance in TRANSPORT (seed 004 §2.3, §3.2): ``control.TransportControl`` orchestrates the rules of its parts,
the attitude (detumbling, hold, tracking), the pushes (the plan flown closed loop, its corrections) and the trim
after the arrival."""
