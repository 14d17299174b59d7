//! Estimates as ROS 2 messages in MCAP.
