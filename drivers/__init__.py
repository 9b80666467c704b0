"""Hardware behind small protocols (Arm, Gripper, Camera, Clock), the safety layer and cells."""
