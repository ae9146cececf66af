"""The synchronized approach to a fast-spinning target (seed 001 section 2): Seweryn and Banaszkiewicz,
*Interception of a free-rotating satellite: an autonomous rendezvous scenario* (seed 001).

Pure numpy/scipy, no ROS. The station point and arrival time of stage 1 and the phase-space link that reaches it
(``station``), and the plan the mission flies (``approach``, with SyncParams, its parameter record of a scenario).
The docking aim is the fly-by's capture target
(flyby_planner.flyby.grasp_search.docking_axis, capture_target_body).
"""
