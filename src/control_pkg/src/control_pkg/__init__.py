"""Application layer: the SMACH task-planning executive of continuous picking."""
