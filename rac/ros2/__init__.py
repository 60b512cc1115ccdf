"""rclpy transports: thin ROS 2 nodes around the engines of :mod:`rac.runtime`.

Importing this package does not import rclpy; each node imports it when it starts
(RAC116 when ROS 2 is not installed).  :mod:`launch` reads ROS 2 launch XML without ROS.
"""
