"""The blackboard keys shared by the perception stage, the runner and the skills."""

FV_LEFT = "/fv/left"
FV_RIGHT = "/fv/right"
ROBOT_POSE = "/robot/pose"
ROBOT_WRENCH = "/robot/wrench"
ROBOT_FAULT = "/robot/fault"
ROBOT_MOVING = "/robot/moving"
GRIPPER_WIDTH = "/gripper/width"
GRIPPER_OBJECT = "/gripper/object"
GRIPPER_FAULT = "/gripper/fault"
GRIPPER_MOVING = "/gripper/moving"
ESTOP = "/task/estop"
ELEMENT = "/task/element"
PLATES = "/task/plates"
ELEMENT_POSE = "/task/element_pose"
ELEMENT_LENGTH = "/task/element_length"
GRASP_WIDTH = "/task/grasp_width"
CONTACT_POSE = "/task/contact_pose"
FORCE_ZERO = "/task/force_zero"  # the TCP force read at rest before contact (N, base frame): a press's zero
LOAD_PROFILE = "/task/load_profile"
LOAD_SCAN = "/task/load_scan"  # the scan in progress: its samples grow in place (for live views)
BEST_POSE = "/task/best_pose"
MEASURED_LOAD = "/task/measured_load"
ASBUILT = "/task/asbuilt"

# Keys written by the perception stage each tick (skills only read them), with their meaning.
PERCEPTION_KEYS = {
    FV_LEFT: "TactileState of the left fingertip",
    FV_RIGHT: "TactileState of the right fingertip",
    ROBOT_POSE: "TCP pose [x, y, z, rx, ry, rz] (m, rad)",
    ROBOT_WRENCH: "TCP force/torque (N, N m)",
    ROBOT_FAULT: "active arm fault text or None",
    ROBOT_MOVING: "a commanded arm move or twist is in progress",
    GRIPPER_WIDTH: "gripper opening (m)",
    GRIPPER_OBJECT: "gripper stopped on an object",
    GRIPPER_FAULT: "active gripper fault text or None",
    GRIPPER_MOVING: "the fingers are moving",
    ESTOP: "e-stop requested",
}

# Keys the task iteration provides to skills.
TASK_KEYS = {
    ELEMENT: "design entry of the element being built (id, size, pick_pose, plate, ...)",
    PLATES: "plate geometry from the design model, by id",
}

# Tactile skill library (Table I): results skills leave for the rest of the tree.
OBJECT_ANGLE = "/task/object_angle"
ARM_ROTATION = "/task/arm_rotation"
PRESS_FORCE = "/task/press_force"
SUBSTANCE = "/task/substance"
STIR_TRIAL = "/task/stir_trial"
