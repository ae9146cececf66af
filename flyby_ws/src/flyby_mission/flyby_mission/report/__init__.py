"""The report library: the figures of a mission run (PNG, matplotlib Agg), from its bag and scenario.

A run directory is what scripts/run_mission.py leaves (bag/, scenario.yaml, summary.json); ``writer.write_report``
draws its figures, scripts/mission_report.py is its command line. Modules: ``loading`` reads the run, ``analysis``,
``sync_analysis`` and ``post_capture_analysis`` compute what the figures draw, ``drawing`` and ``plotting`` are the
shared drawing, and one module per mission kind draws its figures:

``flyby`` (every single-chaser run):

* trajectory_xz.png  chaser path in the hill x-z plane (seed 000 Fig. 11): truth, planned path, the
                     restriction sphere, the target's swept keep-out region and its boxes at the grasp
                     time, burns, start, X_Fi, X_Ft, grasp point; a second panel +-10 m about the target
* trajectory_3d.png  the same in 3-D within +-20 m of the target
* range.png          range and range rate, truth and estimate, over the mission phases and burns
* maneuvers.png      each executed burn's delta-v, commanded against executed
* estimation.png     chaser position / velocity and target attitude / body-rate errors with +-3 sigma
* clearance.png      gap of the chaser envelope to the target's boxes and to the swept region

``rigid_body``, for a six-degree-of-freedom chaser (scenario chaser.model rigid_body; docs/chaser_6dof.md):

* attitude.png       chaser_body in hill (quaternion), truth and estimate; the estimate's attitude error
                     about hill axes with +-3 sigma; the inertial body rate (chaser_body axes)
* pointing.png       truth pointing error of body +x at the target's centre of mass, the window from the
                     first burn to the grasp, the 1 deg requirement and the summary's p95 / max
* wheels.png         reaction wheel speeds and motor torques with their limits
* thrusters.png      each thruster's thrust over time and the thrusters' total torque, with the
                     restriction sphere's entry and exit (no firing inside)

``sync``, for a run of the synchronized approach (summary.json's method sync; docs/synchronized.md), seed 001's figures
(Seweryn and Banaszkiewicz, section 3) from the truth, Euler angles R = Rz(psi) Ry(theta) Rx(phi) as the scenario
reads rpy_rad:

* seed001_fig4_position_velocity.png  Fig 4: the chaser's position and velocity relative to the target in hill, its
                     position in target_body and its thrust acceleration; stages 1-2 and stages 3-4 side by side
* seed001_fig5_euler_sigma.png        Fig 5: standard deviation of the estimated target Euler angles (the estimator's
                     covariance), and their error with +-3 sigma
* seed001_fig6_attitude.png           Fig 6: both bodies' Euler angles and body rates (from stage 3 the target's carried
                     by the relative attitude, which the chaser's follow), the relative attitude and rate
* seed001_fig7_kinetic_energy.png     Fig 7: translational (relative to hill) and rotational kinetic energy of both
                     bodies, and the chaser's wheels' spin energy

``post_capture``, for a scenario with a post_capture section (docs/post_capture.md: CAPTURE -> GRASP -> DAMPING ->
MASS_ESTIMATION), seed 004's Fig 5 (Matsunaga et al., the estimation results) and the phases before it, the truth
from both bodies' truth by flyby_mission's summary functions (the figures of summary.json):

* seed004_fig5_motion.png             Fig 5 (a)-(d) during MASS_ESTIMATION: the combined CoM's position and velocity
                     (truth only: the mission publishes no estimate of them), the combined body's attitude and rate,
                     truth and the chaser attitude filter's estimate with +-3 sigma
* seed004_fig5_mass_properties.png    Fig 5 (e)-(h): the target's principal moments, mass, principal axes and CoM
                     from /estimation/target/inertia with +-3 sigma (the estimator's mass_properties_estimate events),
                     the truth and the prior
* post_capture_grasp_contact.png      the arm's contact force, torque and stroke during GRASP with its limits
* post_capture_damping_momentum.png   the combined body's angular momentum during DAMPING, seed 004's 0.1 kg m^2/s
* seed004_fig7_transport.png          Fig 7 during TRANSPORT (docs/transport.md): the combined body's angular momentum,
                     its CoM's distance to the goal and its speed relative to the goal's circular motion, each
                     against seed 004 §3.2's rendezvous condition, with the thrusters' firings

``two_robots``, for a run of several chasers (a ``chasers:`` scenario, docs/two_robots.md) instead of the above:

* chasers.png        every chaser's truth path in the hill x-z plane with the target's boxes at the least
                     separation; the least distance between two chasers' envelopes over time; each chaser's
                     clearance to the target's boxes (truth attitude)

``faults``, for a run with an injected fault, a detection, a response or a CAM (docs/faults.md):

* faults_timeline.png  each injected fault as a bar over its time, its detections on its row with their delay (the
                     ones no fault explains on a row of false alarms), the supervisor's responses and isolations as
                     labelled lines, the CAM; below, the truth range with the restriction sphere

``families`` draws seed 000 Fig. 6-8 (the fly-by families of flyby_planner, scripts/paper_figures.py).

A figure whose essential data is missing is not written (loading.Skipped); what was left out is said on stderr.
"""
