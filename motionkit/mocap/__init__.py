"""Mocap readers (BVH, ASF/AMC), human skeleton kinematics, CMU clip download (issue 4)."""
