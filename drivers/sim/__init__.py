"""The simulated cell: kinematic arm, one-axis gripper, ground, elements, bendable plate and a
FingerVision contact model. Only what the scenes need; no rigid-body engine."""
