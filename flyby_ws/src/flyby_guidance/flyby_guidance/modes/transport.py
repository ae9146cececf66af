"""Guidance in TRANSPORT after the damping and the excitation (``flyby_guidance.transport.control.TransportControl``).
The estimates stamped from the end of the estimation's window on wait for the estimator's
``mass_properties_estimated``, which starts TRANSPORT, and in TRANSPORT those on the grid of the refined combined CoM
(``transport_navigation.on_com_grid``) for its ``transport_com_estimate`` (the topics race: a rule on stamps gives the
same commands at any pace)."""

import numpy as np

from flyby_estimation.transport_navigation import on_com_grid
from flyby_guidance.damping import PostCaptureCommand
from flyby_guidance.modes.damping import DampingMode
from flyby_guidance.transport.control import TransportControl, transport_body
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import STAMP_TOLERANCE_S


class TransportMode(DampingMode):
    """The damping and the excitation, then TRANSPORT from the final mass-property estimate (module doc)."""

    def __init__(self, params, transport, source, chaser):
        """params: the DampingParams, transport: the TransportParams (flyby_guidance.params); chaser: the
        RigidBodyChaser whose wheels and thrusters it commands."""
        super().__init__(params, source, chaser)
        wheels = chaser.attitude.wheels
        self.transport = TransportControl(transport.control, transport.mean_motion_rad_s, self.post.config.gains,
                                          float(wheels.max_torque_n_m.min()), float(np.min(wheels.max_momentum_n_m_s)))

    def _on_estimator_event(self, event, phase):
        """The final mass-property estimate starts TRANSPORT for the body it gives; the refined combined CoM is flown
        from its stamp on."""
        if event.name == events.MASS_PROPERTIES_ESTIMATED and self.transport.t_start is None:
            self.transport.start(event.t, transport_body(event_payloads.decode(event), self.chaser.mass_kg,
                                                         self.params.chaser_inertia_kg_m2, self.chaser.layout,
                                                         self.transport.config.plume_cone_deg))
            return self._commands(phase)
        if event.name == events.TRANSPORT_COM_ESTIMATE and self.transport.t_start is not None:
            refined = event_payloads.decode(event)
            self.transport.refine_com(event.t, refined.com_body_m, refined.position_sigma_m,
                                      refined.velocity_sigma_mps)
            return self._commands(phase)
        return []

    def _waits(self, t):
        """True for an estimate whose command depends on an estimate of the estimator still on its way: stamped at or
        after the mass-property estimate's end (the excitation's start plus its window) while TRANSPORT has not
        started, or in TRANSPORT on the grid of the refined combined CoM (``transport_com_estimate``) before it."""
        if self.post.t_excitation is None:
            return False
        if self.transport.t_start is not None:  # the combined CoM refined on its grid (estimator's transport nav)
            return on_com_grid(t, self.transport.t_start) and (
                self.transport.t_com is None or self.transport.t_com < t - STAMP_TOLERANCE_S)
        return t >= self.post.t_excitation + self.post.config.window_s - STAMP_TOLERANCE_S

    def _transport_command(self, t, r_hill, v_hill, q_hill_from_body, omega_body, h_wheels_body_n_m_s):
        if self.transport.t_start is not None \
                and t >= self.transport.t_start - STAMP_TOLERANCE_S:  # the excitation is over by then
            return PostCaptureCommand(*self.transport.command(t, r_hill, v_hill, q_hill_from_body, omega_body,
                                                              h_wheels_body_n_m_s))
        return None
