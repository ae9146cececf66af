"""The fly-by capture method: Matsumoto, Dubowsky, Jacobsen and Ohkami, *Fly-by approach and guidance for
uncontrolled rotating satellite capture* (seed 000, sections 3-4.7, eq 10-23 and 28-29; seed 003 section 3 states
it again in short).

Pure numpy/scipy, no ROS. ``search.plan_capture`` takes the estimator's prediction of the target motion
(flyby_estimation.target_motion.MotionPrediction) and the chaser's estimated state, and returns a
``CapturePlan``: the grasp time and point, the offset delta r and the fly-by duration it chose, the
fly-by target point X_Ft (eq 20-21), the fly-by initial point X_Fi (eq 23), the terminal-transfer
impulses (eq 28-29), the predicted passive path and, for every candidate considered, why it was kept
or rejected. The modules, along its steps:

* ``config``: PlannerConfig (the search's bounds, margins, limits), the fly-by's parameter record of a scenario.
* ``grasp_search``: the grasp instants (eq 13-15), the grasp point's closed forms (eq 12, 16-19), X_Ft and X_Fi
  (eq 20-23), the re-solved grasp guidance re-aims at, the capture target of each method.
* ``keepout``: the region the target sweeps about its angular momentum (the passive-safety bound at any timing).
* ``uncertainty``: what the estimators will know at the last burn and the predicted 3-sigma miss (step 4).
* ``passive_safety``: the passive path's gap from the swept region and the predicted geometry (step 4);
  ``predicted_gaps`` and ``check_passage``, which guidance and the optimization-based approach use too.
* ``reaim``: the passage guidance flies once it re-aims, at 3 sigma of the plan estimate (step 4).
* ``candidates``: steps 2-3 and the records (Candidate, CapturePlan); ``checks``: step 4 on a batch;
  ``selection``: step 5 and the refusal's reason; ``search``: plan_capture, the steps in order.
* ``avoidance``: the supervisor's collision-avoidance burn of an abort (the same passive-safety check).
* ``diagnostics``: every fly-by open at a plan time checked, the evidence behind a refusal.
* ``families``: the coasting path families of sections 3.2-3.3 (Fig 5-8), for the paper's figures.

The terminal transfer's impulses (eq 28-29) are flyby_planner.transfer: the CW transfer the transport plan and
guidance use as well.

Steps (seed 000 section 4.4: "multiple candidates ... over a period of rotations"):

1. Grasp-time search (grasp_search.grasp_candidates, eq 13-15) over the grasp times reachable with a
   terminal transfer of transfer_min_s ... transfer_max_s starting maneuver_lead_s from now and any
   searched fly-by duration; for a slow target the window is stretched to hold two turns. When that
   window holds no safe plan, the extended window is searched: transfers up to 0.4 orbit (a tumbler's
   geometry at the grasp changes with its nutation), grasps before the mission's end, and half the
   preferred fly-by for a fast grasp point (its nearer X_Fi and smaller injection).
2. Per grasp instant: condition (a) rate below the category III/IV limit, (b) spin axis away from
   hill y (no pure out-of-plane motion), the safe convex condition eq 15, (c) lighting against the
   sun direction.
3. Per grasp instant that passed, per offset delta r (section 4.3 leaves it "to be set considering
   capturing manipulation capability": searched from offset_min_m to offset_max_m, the
   manipulator's reach less its position tolerance; an offset whose X_Ft touches the target with the attitude
   known exactly is dropped at once) and per fly-by duration (flyby_duration_s and longer, up to
   flyby_duration_max_s): X_Ft, X_Fi; X_Fi outside the thruster-restriction sphere; the
   eq 28-29 impulses within the per-maneuver limit; the transfer, with its execution spread, outside the sphere.
4. Passive safety and the predicted miss, in order of total delta-v: the coast through X_Ft at the grasp time,
   backward to X_Fi and forward over escape_check_orbits orbits (nonlinear relative dynamics,
   flyby_sim.dynamics.orbital), must keep the chaser envelope clearance_margin_m from the target.
   The target is the region it sweeps about its angular momentum (keepout.SweptRegion, good for
   any timing); within geometry_window_s of the grasp, where the swept region is too coarse (a grasp
   point inside the cylinder the panels sweep), the target's *predicted* geometry at each instant
   counts instead. Both are shrunk there by the planner's uncertainty model (uncertainty.EstimateAccuracy,
   TargetUncertainty): 3 sigma of the target estimate the last burn is computed from (its attitude error
   times |r|) and of the chaser's dispersion from that burn on. Guidance's last burn is where the arc is
   still LAST_BURN_SLACK_M beyond the sphere and its burn margin (or the injection); over the unguided coast
   from there the navigation estimate's error (the navigation filter's steady state), the last burn's
   execution error and the target estimate's error at X_Ft give the predicted 3-sigma miss at the grasp,
   which must be within the manipulator's tolerances (it replaces a fixed bound on the coast).
5. Selection, in stages (PlannerConfig.search_stages): the preferred offset and duration (the
   paper's choice) first, then the other offsets, then longer fly-bys; within the first stage that holds a safe
   plan, the least total delta-v of the terminal transfer, and plans within delta_v_tie_mps of it tie and the
   larger least clearance wins. Candidates checked in no stage (dearer than a safe plan, or in a later stage) have
   status 'unchecked'.
"""
