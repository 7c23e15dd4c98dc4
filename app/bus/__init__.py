"""avhear on the robot's network: Zenoh sessions, ROS 2 / ROS4HRI messages in CDR, the robot's sensors.

- :mod:`app.bus.messages`: the topics, frames and message types (REP-155 / hri_msgs), serialised with rosbags.
- :mod:`app.bus.session`: one Zenoh session per process, loopback-only and without multicast scouting by default.
- :mod:`app.sinks.bus`: the sink that publishes every fused result (``avhear run|demo --publish``).
"""
