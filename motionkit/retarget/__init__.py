"""PlaCo inverse kinematics from human motion to the robot."""
