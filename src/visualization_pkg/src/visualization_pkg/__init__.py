"""Presentation layer: robot description (URDF), rviz configuration and the operator dashboard."""
