"""flyby_estimation: placeholder package of the workspace; its capability arrives with its own issue."""
