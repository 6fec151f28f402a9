"""Topic, service and parameter names of visualization_pkg (relative; dashboard.yaml and the
launch files choose the configurable ones, whose defaults are here).

The mission topics and the executive's services are control_pkg's (control_pkg/names.py: the
executive publishes and serves them). visualization_pkg does not depend on control_pkg at run
time, so they are copied here and harvest_bringup's test_contract_names checks the copies.
"""

#: the executive's mission topics
PICK_RECORDS = 'mission/pick_records'       # harvest_msgs/PickRecord
EVENTS = 'mission/events'                   # harvest_msgs/MissionEvent (operator events go there too)
SUMMARY = 'mission/summary'                 # std_msgs/String (JSON totals), latched

#: under the executive node (<executive>/...): its services (std_srvs/Trigger) and state text
EXECUTIVE_START = 'start'
EXECUTIVE_RESUME = 'resume'
EXECUTIVE_EMERGENCY_STOP = 'emergency_stop'
EXECUTIVE_STATE = 'state'                   # std_msgs/String, latched
#: SMACH introspection under <introspection server>/...
SMACH_STRUCTURE = 'smach/container_structure'
SMACH_STATUS = 'smach/container_status'

#: defaults of the dashboard's configurable names (dashboard.yaml key in brackets)
EXECUTIVE = 'task_planner'                  # [executive] control_pkg's task planner node
INTROSPECTION_SERVER = 'harvest_executive'  # [introspection_server]
EMERGENCY_STOP = 'emergency_stop'           # [estop_topic] std_msgs/Bool, latched: true = stop
HALT_ALL = 'halt_all'                       # [halt_service] std_srvs/Trigger (motion_pkg)

JOINT_STATES = 'joint_states'               # sensor_msgs/JointState
TRACK_PICKING_POINTS = 'track/picking_points'   # parameter: the picking points (m along the track)

#: mission_markers: its output, and the actions whose goal and result topics it follows
MARKERS = 'mission/markers'                 # visualization_msgs/MarkerArray, latched
KINEMATICS = 'kinematics'
MOVE_ROBOT = 'move_robot'
