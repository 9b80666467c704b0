"""A run as an MCAP file (`export`): Foxglove's JSON messages (`foxglove`, with the schemas of
`schemas`) or a ROS 2 bag of standard message types in CDR (`ros2`), from the rows of its Rerun
recordings (`rows`)."""
