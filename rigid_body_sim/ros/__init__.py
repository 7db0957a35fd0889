"""The ROS 2 edge of rigid_body_sim: the node, message conversions. The core never imports this."""
