"""Topic, service and parameter names of the simulator (relative; launch files wire them).

Ground truth lives under the `sim` namespace (the world node runs in it); the cameras publish
the names a real camera driver would use.
"""

#: world node (run in namespace `sim`)
JOINT_STATES = 'joint_states'          # sensor_msgs/JointState from the simulated controller
SUCTION_VALVE = 'suction_valve'        # harvest_sim/SuctionValve (stamped), latched, from the simulated controller
SHEAR_CUT = 'shear_cut'                # std_msgs/Header at each shear close
SUCTION_SEALED = 'suction_sealed'      # std_msgs/Bool, latched, world -> controller
FRUITS = 'fruits'                      # harvest_sim/SimFruitArray, latched
GET_SUMMARY = 'get_summary'            # harvest_sim/GetSimSummary
ACTIVITY = 'activity'                  # harvest_sim/SimActivity, controller -> sim_clock
CAMERA_SILENCE = 'camera_silence'      # harvest_sim/CameraSilence, latched, world -> cameras

#: cameras (root namespace)
STEREO_LEFT_IMAGE = 'bumblebee2/left/image_raw'
STEREO_LEFT_INFO = 'bumblebee2/left/camera_info'
STEREO_RIGHT_IMAGE = 'bumblebee2/right/image_raw'
STEREO_RIGHT_INFO = 'bumblebee2/right/camera_info'
HAND_IMAGE = 'hand_camera/image_raw'
HAND_INFO = 'hand_camera/camera_info'
#: std_msgs/Empty: take one frame now (triggered cameras; Gazebo's name for it)
STEREO_TRIGGER = 'bumblebee2/image_trigger'
HAND_TRIGGER = 'hand_camera/image_trigger'

#: clock
CLOCK = '/clock'
CLOCK_HOLD = 'sim/clock_hold'          # harvest_sim/ClockHold, sensors -> sim_clock
CLOCK_ACTIVITY = 'sim/activity'        # harvest_sim/SimActivity, as the clock (root) names it
CAMERA_SILENCE_ROOT = 'sim/camera_silence'   # the same, as the cameras (root) name it

#: global parameter: cart positions (m along map +y) of the picking points
PICKING_POINTS_PARAM = '/track/picking_points'
