"""flyby_guidance: placeholder package of the workspace; its capability arrives with its own issue."""
