"""What skills are made of: the `Skill` base and its declared params, the registry of YAML names,
the blackboard keys, learned model files, and the pieces several skills share (control laws, what
the fingertips feel in tool axes, pose arithmetic, transit paths, the load-peak search, the FollowMe
loop). `behaviours/` itself lists only skills."""
