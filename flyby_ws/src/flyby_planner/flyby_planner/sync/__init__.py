"""The synchronized approach to a fast-spinning target (seed 001 section 2): the station point and arrival time
of stage 1 (``station``) and the plan the mission flies (``approach``)."""
