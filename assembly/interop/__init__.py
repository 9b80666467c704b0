"""Trees and runs in the formats of other tools: BehaviorTree.CPP v4 XML for Groot2 (`btcpp`) and
MCAP for Foxglove and ROS 2 (`mcap`)."""
