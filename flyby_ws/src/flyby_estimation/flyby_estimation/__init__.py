"""flyby_estimation: the estimators: the target attitude MEKF and motion prediction, the relative-navigation filter, the
batch fit, the mass-property estimation after the capture, and EstimatorCore with its node."""
