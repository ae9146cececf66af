"""The point-mass chaser's flight (the plant's default chaser): RK4 split at every burn start and end, thrust
along the burn's fixed hill direction, the mass falling linearly (``Plant`` mixes it in)."""

import math

import numpy as np

from flyby_msgs_py import events
from flyby_msgs_py.wire import Event
from flyby_sim.dynamics.orbital import rk4_step_floats


class PointMassFlight:
    """The point-mass chaser's step and burns, on the state of ``Plant`` (its ``_thrusters``, ``_y``, ``_mass_kg``)."""

    def _step_point_mass(self):
        """One step of the point-mass chaser; returns the TruthSample at the new time."""
        thrusters = self._thrusters
        t = self.t
        self._step_index += 1
        t1 = self.t
        y = self._y
        impulse = [0.0, 0.0, 0.0]
        firing = False
        while t < t1:
            burn = thrusters.active
            if burn is None:
                upcoming = thrusters.next_burn
                if upcoming is None or upcoming.start_s > t:
                    t_end = t1 if upcoming is None else min(t1, upcoming.start_s)
                    y = rk4_step_floats(self._coast_rhs, t, y, t_end - t)
                    t = t_end
                    continue
                burn = self._start_burn(t)
            t_end = min(t1, burn.end_s)
            self._check_restriction(burn, t, y)
            y = rk4_step_floats(self._burn_rhs, t, y, t_end - t)
            mass_end = burn.mass_end_kg if t_end == burn.end_s else self._burn_mass(burn, t_end)
            self._dv_total_mps += thrusters.exhaust_velocity_mps * math.log(self._mass_kg / mass_end)
            force = self.config.thrusters.max_thrust_n * (t_end - t)
            for axis, u in enumerate(burn.direction_hill):
                impulse[axis] += force * u
            self._mass_kg = mass_end
            firing = True
            t = t_end
            self._check_restriction(burn, t, y)
            if t == burn.end_s:
                self._end_burn(t)
        self._y = y
        step_s = self.config.step_s
        self._last = self._truth(np.array(impulse) / step_s, firing)
        self._sample(self._last)
        return self._last


    def _burn_mass(self, burn, t):
        return burn.mass_start_kg - self._thrusters.mass_flow_kg_s * (t - burn.start_s)

    def _start_burn(self, t):
        burn = self._thrusters.start_next()
        thrust_n = self.config.thrusters.max_thrust_n
        ux, uy, uz = burn.direction_hill

        def burn_rhs(tau, y):
            k = thrust_n / self._burn_mass(burn, tau)  # F / m(t), mass falling linearly
            return (y[3], y[4], y[5], *self._accel(y[:3], y[3:], (k * ux, k * uy, k * uz)))

        self._burn_rhs = burn_rhs
        self._restriction_reported = False
        self._events.append(Event(self.t, 'OK', events.BURN_STARTED, f'burn {burn.seq} started at t = {t:.3f} s',
                                  dict(seq=burn.seq, t_cmd=burn.t_cmd_s, t_start=burn.start_s,
                                          t_end=burn.end_s, dv_cmd_hill=burn.dv_cmd_hill,
                                          dv_hill=burn.dv_hill, mass_kg=burn.mass_start_kg)))
        if burn.late:
            lateness = burn.start_s - burn.t_cmd_s
            self._events.append(Event(self.t, 'WARN', events.LATE_MANEUVER,
                                      f'burn {burn.seq} stamped {burn.t_cmd_s:.3f} s started {lateness:.3f} s late',
                                      dict(seq=burn.seq, t_cmd=burn.t_cmd_s, t_start=burn.start_s,
                                              lateness_s=lateness)))
        return burn

    def _end_burn(self, t):
        burn = self._thrusters.finish_active()
        self._burn_rhs = None
        self._events.append(Event(self.t, 'OK', events.BURN_ENDED, f'burn {burn.seq} ended at t = {t:.3f} s',
                                  dict(seq=burn.seq, t_end=t, dv_hill=burn.dv_hill, fuel_kg=burn.fuel_kg,
                                          mass_kg=burn.mass_end_kg)))

    def _check_restriction(self, burn, t, y):
        """Record (once per burn) thrust applied inside the thruster-restriction sphere."""
        x, yy, z = y[:3]
        range_m = math.sqrt(x * x + yy * yy + z * z)
        radius_m = self.config.restriction_sphere_radius_m
        if range_m < radius_m and not self._restriction_reported:
            self._restriction_reported = True
            self._events.append(Event(self.t, 'ERROR', events.THRUST_INSIDE_RESTRICTION_SPHERE,
                                      f'burn {burn.seq} thrusts at {range_m:.3f} m, inside the '
                                      f'{radius_m:.3f} m restriction sphere',
                                      dict(seq=burn.seq, t=t, range_m=range_m,
                                              restriction_sphere_radius_m=radius_m)))
