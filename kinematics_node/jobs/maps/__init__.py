"""Workspace maps: `kinematics reach` (a reachability map of a chain, in chunks of voxels on the
local cores or a Dask cluster, resumable, stored in Reuleaux's HDF5 layout) and `kinematics place`
(base placements from the inverted map). The numbers come from `kinematics_node.core.workspace`;
this package adds the job around them: tasks, files, pictures, markers. Imports the core,
msg_adapters and `jobs.tasks`, never rclpy.
"""
