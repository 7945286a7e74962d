"""Offline jobs around the live loop, ROS-free and batched: recordings (`recordings`: rosbag2 in,
FK, twist, /tf and markers out) and workspace maps (`maps`). Each splits into independent tasks
that `tasks.run_tasks` runs on the local cores or on a Dask distributed cluster. They import the
core, msg_adapters and service, never rclpy.
"""
