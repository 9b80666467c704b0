"""Eyes on the cell: every run recorded as a Rerun recording (`runs/<id>/recording.rrd`), viewed
live (`fvtree run --view`), replayed (`fvtree view RUN_DIR`), and the sensor set-up view."""

IMAGE_HZ = 5.0  # camera frames recorded per second of cell time, by default (`fvtree run --record-images`)
