"""Topic, action and frame names used by vision_pkg (all relative; wired by launch files)."""

# dual_eye_image_capture: inputs (simulated source) and outputs
BUMBLEBEE2_NS = 'bumblebee2'
STEREO_NS = 'stereo'
EYES = ('left', 'right')
IMAGE_RAW = 'image_raw'
CAMERA_INFO = 'camera_info'

# single_eye_image_capture: input (simulated source) and output namespaces
HAND_CAMERA_NS = 'hand_camera'
HAND_EYE_NS = 'hand_eye'

# image_processing inputs
RIGHT_RECT_COLOR = 'stereo/right/image_rect_color'
RIGHT_CAMERA_INFO = 'stereo/right/camera_info'
POINTS2 = 'stereo/points2'
HAND_IMAGE = 'hand_eye/image_raw'
HAND_CAMERA_INFO = 'hand_eye/camera_info'

# image_processing outputs
STEREO_TRIGGER = 'stereo/image_trigger'     # std_msgs/Empty: take a frame now (triggered cameras)
HAND_TRIGGER = 'hand_eye/image_trigger'
IMAGE_PROCESSING_ACTION = 'image_processing'
TOMATO_SCAN_ACTION = 'tomato_scan'
MARKERS = 'detections/markers'
ANNOTATED_IMAGE = 'detections/image'

# default frames
BASE_FRAME = 'base_link'
HAND_OPTICAL_FRAME = 'hand_camera_optical'
