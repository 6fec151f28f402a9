"""Topic, service and parameter names of the task planner (relative; launch files wire them).

The `mission/*` topics are the mission contract: the executive publishes them, and this module is
where they are written. database_pkg, network_pkg and visualization_pkg do not depend on
control_pkg, so each keeps its own copy in its `names` module; harvest_bringup's
test_contract_names checks every copy against this one.
"""

#: published (harvest_msgs; records and events are sent again in full to a late subscriber)
PICK_RECORDS = 'mission/pick_records'       # harvest_msgs/PickRecord, one per fruit
EVENTS = 'mission/events'                   # harvest_msgs/MissionEvent
CHECKPOINTS = 'mission/checkpoints'         # harvest_msgs/Checkpoint, latched: the progress
SUMMARY = 'mission/summary'                 # std_msgs/String (JSON totals), latched
STATE = '~state'                            # std_msgs/String, latched: '<state>: <detail>'

#: subscribed
PLAN = 'plan/picking_points'                # std_msgs/Int32MultiArray, latched (network_pkg's uploader)
EMERGENCY_STOP = 'emergency_stop'           # std_msgs/Bool: true = stop, false = released
JOINT_STATES = 'joint_states'               # sensor_msgs/JointState (schedule pipelined)

#: services of the node (std_srvs/Trigger)
START = '~start'
RESUME = '~resume'
EMERGENCY_STOP_SERVICE = '~emergency_stop'

#: services called
HALT_ALL = 'halt_all'                       # std_srvs/Trigger (motion_pkg)
GET_CHECKPOINT = 'get_checkpoint'           # harvest_msgs/GetCheckpoint (database_pkg)
GET_MISSION_RECORDS = 'get_mission_records'     # harvest_msgs/GetMissionRecords (database_pkg)

#: action server of the self-test node (DO_START's `actions: self_test` in config/executive.yaml)
SELF_TEST = 'self_test'

#: the picking points of the track (m along it), set by the site configuration or the simulator
TRACK_PICKING_POINTS = 'track/picking_points'
#: default ~introspection_name: SMACH introspection under <it>/smach/...
INTROSPECTION_SERVER = 'harvest_executive'
