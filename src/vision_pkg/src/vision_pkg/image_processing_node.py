"""image_processing node (section 3.5.1.2, Figures 20 and 21): ROS glue around detection,
ordering and localisation.

Action servers
  image_processing (harvest_msgs/ImageProcessing, actionlib.ActionServer: concurrent goals,
      each answered on its own)
      SPATIAL_POSITIONING: detect, grade and order the tomatoes in the right rectified colour
          image, 3D pick points from stereo/points2 in ~target_frame (goal override).
      SERVO_FEATURE: the tomato in the hand camera image nearest to the projection of
          target_hint; ServoFeature with found=false when there is none.
  tomato_scan (harvest_msgs/TomatoScan): a SPATIAL_POSITIONING on fresh data plus the number
      of pickable fruit.
Subscribed topics
  stereo/right/image_rect_color, stereo/right/camera_info, stereo/points2 (organized, left
  optical frame), hand_eye/image_raw, hand_eye/camera_info
Published topics
  detections/markers (visualization_msgs/MarkerArray), detections/image (sensor_msgs/Image),
  /diagnostics (input rates), stereo/image_trigger and hand_eye/image_trigger (std_msgs/Empty:
  a goal that needs a fresh frame asks the camera for one, and again every ~trigger_period while
  it waits; a free-running camera ignores them, a triggered one, such as harvest_sim's, takes
  its frames only then)
Timing: every wait and timeout is in ROS time (sim time under /use_sim_time): nothing depends
  on how fast the wall clock runs. Fresh data is judged by stamps: a goal takes the first
  stereo pair (right image and point cloud with equal stamps) or hand image stamped at or after
  its arrival, or after its request stamp (goal_id.stamp) when that is later (a lagging /clock
  here) by at most ~max_request_lead (wall time: two machines' clocks may differ) or, in
  simulated time, by at most SIM_MAX_REQUEST_LEAD (30 s; one /clock for every node).
Parameters (defaults in code and config/image_processing.yaml)
  ~target_frame (base_link), ~min_ripeness (0.7), ~fresh_data (true), ~data_timeout (5.0 s),
  ~max_request_lead (2.0 s), ~tf_timeout (0.5 s), ~row_tolerance_px (40), ~stereo_detection/*
  and ~hand_detection/* (detector parameters, see vision_pkg.detection.DEFAULTS;
  dynamic_reconfigure's colour and fill thresholds apply to both detectors, except keys that
  ~hand_detection sets), ~expected_rate (10 Hz, for diagnostics; 0: frames come on demand, no
  rate check), ~hand_expected_rate (10 Hz; 0 idem), ~trigger_period (1.0 s)
"""
import threading

import actionlib
import message_filters
import rospy
import tf2_geometry_msgs  # noqa: F401  registers PointStamped with tf2
import tf2_ros
from cv_bridge import CvBridge, CvBridgeError
from geometry_msgs.msg import PointStamped
from std_msgs.msg import Empty
from harvest_msgs.msg import (ImageProcessingAction, ImageProcessingGoal, ImageProcessingResult,
                              TomatoScanAction, TomatoScanResult)
from sensor_msgs.msg import CameraInfo, Image, PointCloud2
from visualization_msgs.msg import MarkerArray

from vision_pkg import image_processing_goals as goals
from vision_pkg import localisation, names
from vision_pkg.detection import DEFAULTS as DETECTOR_DEFAULTS
from vision_pkg.detection import TomatoDetector
from vision_pkg.hand_camera import HandCamera
from vision_pkg.image_processing_goals import Aborted, Cancelled, RunningGoal
from vision_pkg.image_processing_outputs import ImageProcessingOutputs
# names that moved out of this module, still importable from it
from vision_pkg.image_processing_goals import stamp_id as _stamp_id  # noqa: F401
from vision_pkg.image_processing_outputs import RATE_TOLERANCE  # noqa: F401
from vision_pkg.image_processing_outputs import NoRateCheck as _NoRateCheck  # noqa: F401

_Goal = RunningGoal
BUFF_SIZE = 16 * 1024 * 1024
#: how many recent right images and clouds the synchronizer keeps to pair them by stamp
IMAGE_HISTORY = 8
#: wall seconds between checks of a data wait's deadline and cancellation when no data comes
#: (data, cancellation and shutdown wake the wait at once; the deadline itself is ROS time)
WAIT_POLL = 0.1
#: hand camera detector defaults that differ from the stereo ones (640x480, full resolution)
HAND_DETECTOR_DEFAULTS = {'scale': 1.0, 'reference_width': 640, 'min_radius_px': 12.0,
                          'max_radius_px': 320.0}


def _detector_params(namespace, overrides):
    params = dict(overrides)
    user = rospy.get_param(namespace, {})
    for key, value in user.items():
        if key not in DETECTOR_DEFAULTS:
            rospy.logwarn('ignoring unknown detector parameter %s/%s', namespace, key)
            continue
        params[key] = type(DETECTOR_DEFAULTS[key])(value)
    return params


class ImageProcessingNode(HandCamera, ImageProcessingOutputs):
    """See module docstring. SERVO_FEATURE and the hand camera: HandCamera (hand_camera.py);
    diagnostics, annotated image and markers: ImageProcessingOutputs
    (image_processing_outputs.py); results: image_processing_goals.py."""

    def __init__(self):
        self.target_frame = rospy.get_param('~target_frame', names.BASE_FRAME)
        self.min_ripeness = float(rospy.get_param('~min_ripeness', 0.7))
        self.fresh_data = bool(rospy.get_param('~fresh_data', True))
        self.data_timeout = float(rospy.get_param('~data_timeout', 5.0))
        # in simulated time every node reads one /clock, so a request stamped ahead is this
        # node's clock lagging on a busy machine (3.4 s seen under a 1-core CPU quota), never
        # two machines' clocks apart: only a lead beyond SIM_MAX_REQUEST_LEAD is doubted
        self.sim_time = bool(rospy.get_param('/use_sim_time', False))
        self.max_request_lead = rospy.Duration(
            goals.SIM_MAX_REQUEST_LEAD if self.sim_time else
            float(rospy.get_param('~max_request_lead', 2.0)))
        self.tf_timeout = float(rospy.get_param('~tf_timeout', 0.5))
        # a pickable tomato's fitted sphere must have a tomato's size (leaves and stems do not)
        self.min_fruit_radius = float(rospy.get_param('~min_fruit_radius', 0.018))
        self.max_fruit_radius = float(rospy.get_param('~max_fruit_radius', 0.055))
        # a fruit cut by the image border has a wrong circle and 3D point: pick it from the next point
        self.border_margin_px = float(rospy.get_param('~border_margin_px', 4.0))
        self.row_tolerance = float(rospy.get_param('~row_tolerance_px', 40.0))
        self.trigger_period = rospy.Duration.from_sec(float(rospy.get_param('~trigger_period',
                                                                            1.0)))
        self.stereo_detector = TomatoDetector(**_detector_params('~stereo_detection', {}))
        hand_params = _detector_params('~hand_detection', HAND_DETECTOR_DEFAULTS)
        self.hand_detector = TomatoDetector(**hand_params)
        #: detector keys the hand camera sets itself: live reconfigure leaves them alone
        self._hand_own = set(hand_params)
        self.bridge = CvBridge()
        # a long cache: in accelerated sim time a loaded machine may process a stereo pair
        # tens of simulated seconds after it was taken, and its tf must still be there
        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(float(rospy.get_param('~tf_cache', 120.0))))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)

        self._cond = threading.Condition()
        self._pair = None          # (right image, cloud) of the latest pair with equal stamps
        self._right_info = None
        self._hand_image = None
        self._hand_info = None
        self._cache_lock = threading.Lock()
        self._cache = (None, None)     # (stamp, [(detection, location)]) of the last pair
        self._goals = {}               # goal id -> RunningGoal, for image_processing
        self._scan_goal = None         # RunningGoal of the tomato_scan goal being served

        self._setup_diagnostics()
        self.marker_pub = rospy.Publisher(names.MARKERS, MarkerArray, queue_size=1, latch=True)
        self.image_pub = rospy.Publisher(names.ANNOTATED_IMAGE, Image, queue_size=1, latch=True)
        self.stereo_trigger = rospy.Publisher(names.STEREO_TRIGGER, Empty, queue_size=1)
        self.hand_trigger = rospy.Publisher(names.HAND_TRIGGER, Empty, queue_size=1)
        # the right image and the cloud computed from it carry the same stamp: an exact-time
        # synchronizer pairs them (IMAGE_HISTORY messages of each are kept for the match)
        image_sub = message_filters.Subscriber(names.RIGHT_RECT_COLOR, Image, queue_size=1,
                                               buff_size=BUFF_SIZE, tcp_nodelay=True)
        cloud_sub = message_filters.Subscriber(names.POINTS2, PointCloud2, queue_size=1,
                                               buff_size=BUFF_SIZE, tcp_nodelay=True)
        image_sub.registerCallback(lambda _m: self._freq[names.RIGHT_RECT_COLOR].tick())
        cloud_sub.registerCallback(lambda _m: self._freq[names.POINTS2].tick())
        self._sync = message_filters.TimeSynchronizer([image_sub, cloud_sub], IMAGE_HISTORY)
        self._sync.registerCallback(self._on_stereo_pair)
        self._subs = [
            image_sub, cloud_sub,
            rospy.Subscriber(names.RIGHT_CAMERA_INFO, CameraInfo, self._on_right_info,
                             queue_size=1),
            rospy.Subscriber(names.HAND_IMAGE, Image, self._on_hand_image, queue_size=1,
                             buff_size=BUFF_SIZE, tcp_nodelay=True),
            rospy.Subscriber(names.HAND_CAMERA_INFO, CameraInfo, self._on_hand_info,
                             queue_size=1),
        ]
        self._reconfigure = None
        self._start_reconfigure()
        self.server = actionlib.ActionServer(names.IMAGE_PROCESSING_ACTION, ImageProcessingAction,
                                             self._on_goal, self._on_cancel, auto_start=False)
        self.scan_server = actionlib.SimpleActionServer(names.TOMATO_SCAN_ACTION,
                                                        TomatoScanAction, auto_start=False)
        self.scan_server.register_goal_callback(self._on_scan_goal)
        self.scan_server.register_preempt_callback(self._on_scan_preempt)
        self.server.start()
        self.scan_server.start()
        rospy.loginfo('image_processing: action servers %s and %s ready',
                      names.IMAGE_PROCESSING_ACTION, names.TOMATO_SCAN_ACTION)

    # -- set-up (diagnostics: image_processing_outputs) ---------------------------------------
    def _start_reconfigure(self):
        try:
            from dynamic_reconfigure.server import Server
            from vision_pkg.cfg import ImageProcessingConfig
        except ImportError:
            rospy.logwarn('image_processing: dynamic_reconfigure config not built; thresholds '
                          'are fixed at start-up')
            return
        self._reconfigure = Server(ImageProcessingConfig, self._on_reconfigure)

    def _on_reconfigure(self, config, _level):
        self.min_ripeness = config['min_ripeness']
        self.row_tolerance = config['row_tolerance_px']
        update = {key: config[key] for key in ('hue_max', 'hue_wrap', 'sat_min', 'val_min',
                                               'min_fill', 'min_fill_green')}
        self.stereo_detector.update(**update)
        self.hand_detector.update(**dict((k, v) for k, v in update.items()
                                         if k not in self._hand_own))
        with self._cache_lock:
            self._cache = (None, None)
        return config

    def shutdown(self):
        self._diag_timer.shutdown()
        for goal in list(self._goals.values()):
            goal.cancelled.set()
        with self._cond:
            self._cond.notify_all()

    # -- inputs (the hand camera's: hand_camera) ----------------------------------------------
    def _on_stereo_pair(self, image, cloud):
        with self._cond:
            self._pair = (image, cloud)
            self._cond.notify_all()

    def _on_right_info(self, msg):
        with self._cond:
            self._right_info = msg

    def _wait(self, ready, goal, what, trigger=None):
        """Block until ready() returns a value (under the lock); Aborted after ~data_timeout of
        ROS time. trigger: publisher of the camera's image_trigger, fired at the start and every
        ~trigger_period while nothing comes."""
        start_ros = rospy.get_rostime()
        deadline = rospy.Duration.from_sec(self.data_timeout)
        next_trigger = start_ros
        with self._cond:
            while True:
                value = ready()
                if value is not None:
                    return value
                if goal.cancelled.is_set():
                    raise Cancelled()
                if rospy.is_shutdown():
                    raise Aborted('node shutting down')
                now = rospy.get_rostime()
                if now - start_ros > deadline:
                    raise Aborted('no %s within %.1f s' % (what, self.data_timeout))
                if trigger is not None and now >= next_trigger:
                    trigger.publish(Empty())
                    next_trigger = now + self.trigger_period
                self._cond.wait(WAIT_POLL)

    def _stereo_pair(self, goal, since):
        """(image msg, cloud msg, right camera_info) with equal stamps, stamped at/after since."""
        def ready():
            pair = self._pair
            if pair is None or self._right_info is None or pair[1].header.stamp < since:
                return None
            return pair[0], pair[1], self._right_info
        return self._wait(ready, goal, 'stereo image + point cloud pair with matching stamps%s'
                          % (' received after the request' if since.to_sec() > 0 else '')
                          + ' on %s and %s' % (names.RIGHT_RECT_COLOR, names.POINTS2),
                          self.stereo_trigger)

    # -- image_processing action --------------------------------------------------------------
    def _on_goal(self, handle):
        goal = handle.get_goal()
        gid = handle.get_goal_id().id
        state = RunningGoal()
        self._goals[gid] = state
        handle.set_accepted()
        fresh_from = self._fresh_since(handle.get_goal_id().stamp)
        worker = threading.Thread(target=self._serve, args=(handle, goal, state, gid, fresh_from),
                                  name='image_processing_goal')
        worker.daemon = True
        worker.start()

    def _fresh_since(self, requested):
        """ROS time from which a goal requested at `requested` takes data (fresh_since)."""
        arrival = rospy.get_rostime()
        since, skewed = goals.fresh_since(arrival, requested, self.max_request_lead)
        if skewed:
            rospy.logwarn_throttle(10.0, 'image_processing: a goal stamped %.3f s ahead of this '
                                   'node\'s clock (%s): fresh data count from its arrival' % (
                                       (requested - arrival).to_sec(),
                                       'a client on another time base?' if self.sim_time else
                                       'clocks of two machines apart?'))
        return since

    def _on_cancel(self, handle):
        state = self._goals.get(handle.get_goal_id().id)
        if state is not None:
            state.cancelled.set()
            with self._cond:
                self._cond.notify_all()

    def _serve(self, handle, goal, state, gid, fresh_from):
        result = ImageProcessingResult()
        try:
            if goal.request == ImageProcessingGoal.SPATIAL_POSITIONING:
                result.tomatoes = self.spatial_positioning(goal.target_frame, goal.min_ripeness,
                                                           state, fresh_from)
                result.message = goals.positioning_message(result.tomatoes)
            elif goal.request == ImageProcessingGoal.SERVO_FEATURE:
                result.feature = self.servo_feature(goal.target_hint, state, fresh_from)
                result.message = goals.servo_message(result.feature)
            else:
                raise Aborted('unknown request %d (SPATIAL_POSITIONING=0, SERVO_FEATURE=1)'
                              % goal.request)
            result.success = True
            handle.set_succeeded(result, result.message)
        except Cancelled:
            result.message = 'cancelled'
            handle.set_canceled(result, result.message)
        except Aborted as exc:
            result.success = False
            result.message = str(exc)
            rospy.logwarn_throttle(2.0, 'image_processing goal aborted: %s' % exc)
            handle.set_aborted(result, result.message)
        finally:
            self._goals.pop(gid, None)

    # -- tomato_scan action -------------------------------------------------------------------
    def _on_scan_goal(self):
        if self._scan_goal is not None:
            self._scan_goal.cancelled.set()
        goal = self.scan_server.accept_new_goal()
        state = RunningGoal()
        self._scan_goal = state
        since = self._fresh_since(self.scan_server.current_goal.get_goal_id().stamp)
        worker = threading.Thread(target=self._serve_scan, args=(goal, state, since),
                                  name='tomato_scan')
        worker.daemon = True
        worker.start()

    def _on_scan_preempt(self):
        if self._scan_goal is not None:
            self._scan_goal.cancelled.set()
            with self._cond:
                self._cond.notify_all()

    def _serve_scan(self, goal, state, fresh_from):
        result = TomatoScanResult()
        try:
            result.tomatoes = self.spatial_positioning(goal.target_frame, 0.0, state, fresh_from)
            result.pickable_count = goals.pickable_count(result.tomatoes)
            result.success = True
            result.message = goals.scan_message(goal.picking_point, result.tomatoes,
                                                result.pickable_count)
            outcome = 'succeeded'
        except Cancelled:
            result.message = 'preempted'
            outcome = 'preempted'
        except Aborted as exc:
            result.message = str(exc)
            outcome = 'aborted'
        if self._scan_goal is not state:      # superseded by a newer goal: that one answers
            return
        self._scan_goal = None
        if outcome == 'succeeded':
            self.scan_server.set_succeeded(result, result.message)
        elif outcome == 'preempted':
            self.scan_server.set_preempted(result, result.message)
        else:
            rospy.logwarn_throttle(2.0, 'tomato_scan aborted: %s' % result.message)
            self.scan_server.set_aborted(result, result.message)

    # -- the two requests (SERVO_FEATURE: hand_camera) ----------------------------------------
    def spatial_positioning(self, target_frame, min_ripeness, state, fresh_from):
        """TomatoArray for the next stereo pair (see module docstring)."""
        threshold = goals.ripeness_threshold(min_ripeness, self.min_ripeness)
        frame = target_frame or self.target_frame
        since = fresh_from if self.fresh_data else rospy.Time(0)
        image_msg, cloud_msg, info = self._stereo_pair(state, since)
        found = self._detect_and_locate(image_msg, cloud_msg, info)
        cloud_frame = cloud_msg.header.frame_id
        try:
            transform = self.tf_buffer.lookup_transform(
                frame, cloud_frame, cloud_msg.header.stamp, rospy.Duration(self.tf_timeout))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                tf2_ros.ExtrapolationException) as exc:
            raise Aborted('no transform %s -> %s at the image time: %s'
                          % (cloud_frame, frame, exc))
        entries = []
        for det, loc in found:
            point = None
            if loc is not None:
                ps = PointStamped()
                ps.header = cloud_msg.header
                ps.point.x, ps.point.y, ps.point.z = (float(c) for c in loc.centre)
                point = tf2_geometry_msgs.do_transform_point(ps, transform)
            plausible = goals.plausible_fruit(det, loc, image_msg.width, image_msg.height,
                                              self.min_fruit_radius, self.max_fruit_radius,
                                              self.border_margin_px)
            if loc is not None and not plausible:
                rospy.logdebug('image_processing: detection at (%.0f, %.0f) px, radius %.1f mm, not '
                               'pickable: cut by the image border or not a tomato\'s size', det.u, det.v,
                               loc.radius * 1000.0)
            entries.append((det, loc, point, point is not None and plausible and det.score >= threshold))
        sequence = goals.picking_sequence(entries, self.row_tolerance)
        array = goals.tomato_array(image_msg.header, image_msg.width, image_msg.height, entries,
                                   sequence, frame, cloud_msg.header.stamp)
        self._publish_visuals(array, [entries[i][0] for i in sequence], image_msg, frame)
        return array

    def _detect_and_locate(self, image_msg, cloud_msg, info):
        stamp = image_msg.header.stamp
        with self._cache_lock:
            if self._cache[0] == stamp:
                return self._cache[1]
        try:
            bgr = self.bridge.imgmsg_to_cv2(image_msg, 'bgr8')
        except CvBridgeError as exc:
            raise Aborted('cannot convert %s: %s' % (names.RIGHT_RECT_COLOR, exc))
        offsets = {f.name: f.offset for f in cloud_msg.fields}
        if not all(k in offsets for k in 'xyz'):
            raise Aborted('%s has no x, y, z fields' % names.POINTS2)
        if cloud_msg.height <= 1:
            raise Aborted('%s is not organized (height %d)' % (names.POINTS2, cloud_msg.height))
        cloud = localisation.cloud_array(cloud_msg.data, cloud_msg.height, cloud_msg.width,
                                         cloud_msg.point_step, cloud_msg.row_step,
                                         (offsets['x'], offsets['y'], offsets['z']),
                                         cloud_msg.is_bigendian)
        detections = self.stereo_detector.detect(bgr)
        sizes = (self.min_fruit_radius, self.max_fruit_radius)
        found = list(zip(detections, localisation.locate_all(cloud, detections, info.P, image=bgr,
                                                             radius_range=sizes)))
        # a fruit whose part is mostly something in front of it is graded by its own skin
        found = localisation.regrade(self.stereo_detector, cloud, found, info.P, bgr)
        with self._cache_lock:
            self._cache = (stamp, found)
        return found
