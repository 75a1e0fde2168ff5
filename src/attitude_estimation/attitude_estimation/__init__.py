"""The attitude estimator node: an MEKF on star tracker and gyro (Markley and Crassidis)."""
