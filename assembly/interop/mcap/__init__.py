"""A run as an MCAP file for Foxglove and ROS 2 tools (`export`) and the schemas of its messages (`schemas`)."""
