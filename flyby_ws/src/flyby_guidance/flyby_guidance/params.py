"""Guidance's parameter record (``GuidanceParams``): one frozen record of every scenario key guidance reads, with a
sub-record for each of its modes (``flyby_guidance.modes``), None for a mode the scenario does not fly
(``flyby_msgs_py.params``; the keys' defaults, ranges and descriptions are the scenario schema's).

A mode's config that is all scenario keys is its own record (``guidance.GuidanceConfig``, ``tracking.TrackingConfig``,
``sync_control.SyncConfig``, ``damping.PostCaptureConfig``, ``transport.control.TransportGuidanceConfig``, the
planner's ``PlannerConfig`` the fly-by's re-aim checks with); the records here add what a mode reads besides it.
No ROS here.
"""

import numpy as np

from flyby_estimation.target_filter import ConvergenceThresholds
from flyby_guidance.attitude_guidance import AttitudeGuidanceConfig
from flyby_guidance.damping import PostCaptureConfig
from flyby_guidance.guidance import GuidanceConfig
from flyby_guidance.sync_control import SyncConfig
from flyby_guidance.tracking import TrackingConfig
from flyby_guidance.transport.control import TransportGuidanceConfig
from flyby_msgs_py import params
from flyby_planner.flyby.config import PlannerConfig
from flyby_sim.dynamics.rigid_body import ReactionWheels


def _rigid(scenario):
    return scenario.chaser.model == 'rigid_body'


def _captures(scenario):
    """A rigid-body chaser with a post_capture section: guidance commands the combined body after the capture."""
    return _rigid(scenario) and scenario.post_capture is not None


def _transports(scenario):
    return _captures(scenario) and scenario.post_capture.transport is not None


def _initial_wheel_momentum(scenario):
    """The wheels' initial momenta [N m s] (chaser.wheels.initial_momentum_n_m_s; omitted: none)."""
    h0 = scenario.chaser.wheels.initial_momentum_n_m_s
    return np.zeros(len(scenario.chaser.wheels.axes)) if h0 is None else np.array(h0, float)


def _attached_distance_m(scenario):
    """Between the two CoMs in a run that starts attached [m] (post_capture.attachment), None after a capture."""
    pc = scenario.post_capture
    if pc.start != 'attached':
        return None
    return float(np.linalg.norm(pc.attachment.target_com_chaser_body_m))


@params.record
class FlybyParams:
    """The fly-by's adjusting burns (``modes.flyby``): guidance's settings, the planner's (its re-aim's passage
    check, the first burn's lead), and what the re-aim predicts the target with."""

    guidance: GuidanceConfig = params.sub(GuidanceConfig)
    planner: PlannerConfig = params.sub(PlannerConfig)
    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    target_inertia_kg_m2: np.ndarray = params.key('target_inertia')
    torque_psd_n2m2s: float = params.key('estimation.torque_psd_n2m2s')
    x_grasp_body_m: np.ndarray = params.key('target.grasp_point_body_m', np.array)
    refine_target: bool = params.key('guidance.refine_target')
    convergence: ConvergenceThresholds = params.sub(ConvergenceThresholds)  # the re-aim's: a converged estimate


@params.record
class ChaserParams:
    """The rigid-body chaser (``modes.chaser``): its attitude control, wheels, mass, inertia and thrusters."""

    control_period_s: float = params.key('sensors.chaser_imu.rate_hz', lambda hz: 1.0 / hz)
    momentum_dump_start_n_m_s: float = params.key('guidance.momentum_dump_start_n_m_s')
    momentum_dump_stop_n_m_s: float = params.key('guidance.momentum_dump_stop_n_m_s')
    wheels: ReactionWheels = params.key('reaction_wheels')
    initial_wheel_momentum_n_m_s: np.ndarray = params.derived(_initial_wheel_momentum)
    inertia_kg_m2: np.ndarray = params.key('chaser_inertia')
    mass_kg: float = params.key('chaser.mass_kg')
    restriction_sphere_radius_m: float = params.key('planner.restriction_sphere_radius_m')
    thruster_layout: object = params.key('thruster_layout')
    mean_motion_rad_s: float = params.key('mean_motion_rad_s')

    def attitude_config(self):
        """The pointing's AttitudeGuidanceConfig: the IMU's period and guidance's momentum dump."""
        return AttitudeGuidanceConfig(control_period_s=self.control_period_s,
                                      dump_start_n_m_s=self.momentum_dump_start_n_m_s,
                                      dump_stop_n_m_s=self.momentum_dump_stop_n_m_s)


@params.record
class DampingParams:
    """The damping and the excitation after the arm's lock (``modes.damping``): the law's settings and what bounds
    the combined body's inertia."""

    post: PostCaptureConfig = params.sub(PostCaptureConfig)
    attached_distance_m: float = params.derived(_attached_distance_m)
    chaser_inertia_kg_m2: np.ndarray = params.key('chaser_inertia')
    target_inertia_kg_m2: np.ndarray = params.key('target_inertia')
    chaser_mass_kg: float = params.key('chaser.mass_kg')
    target_mass_kg: float = params.key('target.mass_kg')


@params.record
class TransportParams:
    """TRANSPORT (``modes.transport``): its rules' settings and the orbit's mean motion."""

    control: TransportGuidanceConfig = params.sub(TransportGuidanceConfig)
    mean_motion_rad_s: float = params.key('mean_motion_rad_s')


@params.record
class GuidanceParams:
    """Everything guidance reads of a scenario, by mode (module doc): the fly-by always; the rigid-body chaser, its
    tracking and synchronized hold with ``chaser.model: rigid_body``; the damping with a post_capture section on it,
    the transport with post_capture.transport."""

    flyby: FlybyParams = params.sub(FlybyParams)
    chaser: ChaserParams = params.sub(ChaserParams, when=_rigid)
    tracking: TrackingConfig = params.sub(TrackingConfig, when=_rigid)
    synchronized: SyncConfig = params.sub(SyncConfig, when=_rigid)
    damping: DampingParams = params.sub(DampingParams, when=_captures)
    transport: TransportParams = params.sub(TransportParams, when=_transports)
