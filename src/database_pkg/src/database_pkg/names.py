"""Topic, service and action names of database_node (relative; wired by launch remaps).

The `mission/*` topics are the executive's (control_pkg/names.py writes them); database_pkg does
not depend on control_pkg, so they are copied here and harvest_bringup's test_contract_names
checks the copies against control_pkg's.
"""

#: subscribed: the executive's mission topics
PICK_RECORDS = 'mission/pick_records'       # harvest_msgs/PickRecord: one row each
EVENTS = 'mission/events'                   # harvest_msgs/MissionEvent: one row each
CHECKPOINTS = 'mission/checkpoints'         # harvest_msgs/Checkpoint: one row per mission

#: services offered
GET_MISSION_RECORDS = 'get_mission_records'     # harvest_msgs/GetMissionRecords
GET_CHECKPOINT = 'get_checkpoint'               # harvest_msgs/GetCheckpoint

#: actions: served (DO_SPATIAL_TEMPORAL) and called (vision_pkg's scan)
SPATIAL_TEMPORAL = 'spatial_temporal'
IMAGE_PROCESSING = 'image_processing'
