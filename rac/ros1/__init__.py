"""rospy transports: thin nodes around the engines of :mod:`rac.runtime`.

Importing this package does not import rospy; each node imports it when it starts
(RAC057 when ROS 1 is not installed).
"""
