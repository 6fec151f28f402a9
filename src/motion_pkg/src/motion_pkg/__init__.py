"""Sense layer, motion: arm kinematics, the Modbus TCP driver of the multi-axis controller and the motion action servers."""
