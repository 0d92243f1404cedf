"""What the tests share (nothing here is collected as a test):

- ``rig``: ``Rig``, the virtual bus with the real node process on it and an rclpy listener; the
  servo model numbers and parameter sets the tests use.
- ``ros``: ``NodeProcess`` (a node as a process, its log line by line), ``node_command``,
  ``TopicClient``, ``spin_until``.
- ``msg_fill``: every field of a generated message filled with distinct values (a script too).
- ``load_publisher``: the load test's command publisher, run as a process of its own.
- ``launch_runner``: reads a launch file as ``ros2 launch`` would and lists the nodes it starts.
- ``sdk``: ``PatientPort``, the SDK's port with a reply wait long enough for a loaded machine.
"""
