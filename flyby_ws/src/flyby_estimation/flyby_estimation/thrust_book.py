"""What the commands lead the navigation filter to expect of each IMU interval, against what the accelerometer
measured: the residual the thrust monitor judges (``health.ThrustMonitor``, docs/faults.md). Split from ``health``,
which holds the monitors' rules; this is their bookkeeping of guidance's force commands and the maneuvers' burns.
Pure numpy."""

import numpy as np

from flyby_estimation.thrust_isolation import BurnShare, Commanded
from flyby_msgs_py.stamped import put_bounded, stamp_key
from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate

BIT_THRUSTERS = 2  # a commanded wrench may miss this many thrusters' minimum impulse bit


class ThrustBook:
    """What the commands lead the navigation filter to expect of each IMU interval, against what the accelerometer
    measured, one interval late (a force command may come after its interval's sample): the residual the
    ``ThrustMonitor`` judges."""

    def __init__(self, lever_min_m, bit_force_n):
        """lever_min_m: the least moment arm of a thruster about the CoM: a couple of T N m fires at most
        T / lever_min_m of thrust; bit_force_n: the minimum impulse bit over a control period [N], the force a
        thruster left off below it does not give."""
        self.lever_min_m = lever_min_m
        self.bit_force_n = bit_force_n
        self.maneuvers = set()  # the seqs of the filter's burns that are guidance's maneuvers (not force commands)
        self.burns = {}  # seq -> the filter's ScheduledBurn as last scheduled
        self.burn_frames = {}  # seq -> q_body_from_hill as it started: the plant's burn is fixed in the body then
        # interval start -> (delta-v [m/s, hill], total thrust [N], granularity [N]: the force BIT_THRUSTERS left
        # off below their minimum impulse bit may not give, 0 for no thrust; the force [N] and torque [N m] commanded,
        # chaser_body: what the isolation allocates)
        self.commands = {}
        self.pending = None  # the last interval, judged at the next

    def on_maneuver(self, seq):
        """The filter's burn ``seq`` is a maneuver's (the plant's burn), expected of the thrusters."""
        self.maneuvers.add(seq)

    def on_burns(self, burns):
        """The filter's burns as scheduled now (``RelativeNavFilter.burns``); a finished one keeps its last."""
        for b in burns:
            if b.seq in self.maneuvers:
                self.burns[b.seq] = b

    def on_command(self, t, dv_hill, force_n, torque_n_m):
        """A force command held over the interval from t: its delta-v as the filter takes it, its thrust."""
        thrust = float(np.linalg.norm(force_n)) + float(np.linalg.norm(torque_n_m)) / self.lever_min_m
        granularity = BIT_THRUSTERS * self.bit_force_n if thrust > 0.0 else 0.0
        put_bounded(self.commands, stamp_key(t), (np.asarray(dv_hill, dtype=float), thrust, granularity,
                                                  tuple(map(float, force_n)), tuple(map(float, torque_n_m))))

    def on_interval(self, t0, t1, dv_measured_hill, q_body_from_hill, mass_kg):
        """The accelerometer's delta-v [m/s, hill] over [t0, t1]; returns the previous interval's (residual specific
        force, expected thrust acceleration [m/s^2], the force commands' acceleration [m/s^2, chaser_body], the
        minimum impulse bit's granularity [m/s^2], its burns' edges: (seq, acceleration [m/s^2], start, end) of each
        burn starting or ending in it, and what it commanded of the thrusters: ``thrust_isolation.Commanded``), or
        None."""
        judged = None
        if self.pending is not None:
            p0, p1, measured, q, mass, burn_dv, burn_thrust, edges, shares = self.pending
            commanded, thrust, granularity, force, torque = self.commands.pop(
                stamp_key(p0), (np.zeros(3), 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
            dt = p1 - p0
            residual_hill = (measured - burn_dv - commanded) / dt
            judged = (quat_rotate(q, residual_hill), burn_thrust / dt + thrust / mass, quat_rotate(q, commanded / dt),
                      granularity / mass, edges, Commanded(dt, mass, force, torque, shares))
        burn_dv, burn_speed, edges, shares = np.zeros(3), 0.0, [], []
        q_hill_from_body = quat_conjugate(q_body_from_hill)
        for b in self.burns.values():
            overlap = min(t1, b.end_s) - max(t0, b.start_s)
            if overlap > 0.0:
                q_start = self.burn_frames.setdefault(b.seq, q_body_from_hill)  # within an interval of its start
                accel = quat_rotate(q_hill_from_body,
                                    quat_rotate(q_start, b.accel_hill(0.5 * (max(t0, b.start_s) + min(t1, b.end_s)))))
                burn_dv, burn_speed = burn_dv + accel * overlap, burn_speed + float(np.linalg.norm(accel)) * overlap
                shares.append(BurnShare(b.seq, tuple(quat_rotate(q_start, b.direction_hill).tolist()),
                                        float(np.linalg.norm(b.dv_hill)), float(b.thrust_n), float(b.mass_start_kg),
                                        float(np.linalg.norm(accel)), overlap))
                starts, ends = t0 <= b.start_s <= t1, t0 <= b.end_s <= t1
                if starts or ends:  # its timing may differ from the plant's (ThrustMonitor.judge)
                    edges.append((b.seq, float(np.linalg.norm(accel)), starts, ends))
        self.burns = {seq: b for seq, b in self.burns.items() if b.end_s > t0}
        self.burn_frames = {seq: q for seq, q in self.burn_frames.items() if seq in self.burns}
        self.pending = (t0, t1, np.asarray(dv_measured_hill, dtype=float), q_body_from_hill, mass_kg, burn_dv,
                        burn_speed, tuple(edges), tuple(shares))
        return judged
