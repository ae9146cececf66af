"""flyby_mission: the mission as a whole, above the method packages: the supervisor (core and node), the headless
driver, the launcher's library, the run and fleet summaries, campaigns and the report library."""
