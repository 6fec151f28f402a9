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
  its arrival.
Parameters (defaults in code and config/image_processing.yaml)
  ~target_frame (base_link), ~min_ripeness (0.7), ~fresh_data (true), ~data_timeout (5.0 s),
  ~tf_timeout (0.5 s), ~row_tolerance_px (40), ~stereo_detection/* and ~hand_detection/*
  (detector parameters, see vision_pkg.detection.DEFAULTS; dynamic_reconfigure's colour and
  fill thresholds apply to both detectors, except keys that ~hand_detection sets), ~expected_rate (10 Hz, for
  diagnostics; 0: frames come on demand, no rate check), ~hand_expected_rate (10 Hz; 0 idem),
  ~trigger_period (1.0 s)
"""
import math
import threading

import actionlib
import message_filters
import cv2
import numpy as np
import rospy
import tf2_geometry_msgs  # noqa: F401  registers PointStamped with tf2
import tf2_ros
import diagnostic_updater
from cv_bridge import CvBridge, CvBridgeError
from geometry_msgs.msg import PointStamped
from std_msgs.msg import Empty
from harvest_msgs.msg import (ImageProcessingAction, ImageProcessingGoal, ImageProcessingResult,
                              ServoFeature, Tomato, TomatoArray, TomatoScanAction,
                              TomatoScanResult)
from sensor_msgs.msg import CameraInfo, Image, PointCloud2
from visualization_msgs.msg import Marker, MarkerArray

from vision_pkg import annotate, localisation, names, ordering
from vision_pkg.detection import DEFAULTS as DETECTOR_DEFAULTS
from vision_pkg.detection import TomatoDetector

BUFF_SIZE = 16 * 1024 * 1024
#: how many recent right images and clouds the synchronizer keeps to pair them by stamp
IMAGE_HISTORY = 8
#: wall seconds between checks of a data wait's deadline and cancellation when no data comes
#: (data, cancellation and shutdown wake the wait at once; the deadline itself is ROS time)
WAIT_POLL = 0.1
#: accepted input-rate band for diagnostics, as a fraction of the expected rate
RATE_TOLERANCE = 0.5
#: hand camera detector defaults that differ from the stereo ones (640x480, full resolution)
HAND_DETECTOR_DEFAULTS = {'scale': 1.0, 'min_radius_px': 12.0, 'max_radius_px': 320.0}


class Aborted(Exception):
    """A goal cannot be served; the message goes into the result."""


class Cancelled(Exception):
    """The client cancelled the goal."""


def _detector_params(namespace, overrides):
    params = dict(overrides)
    user = rospy.get_param(namespace, {})
    for key, value in user.items():
        if key not in DETECTOR_DEFAULTS:
            rospy.logwarn('ignoring unknown detector parameter %s/%s', namespace, key)
            continue
        params[key] = type(DETECTOR_DEFAULTS[key])(value)
    return params


def _stamp_id(stamp):
    return 'stereo_right_%d.%09d' % (stamp.secs, stamp.nsecs)


class _NoRateCheck(object):
    """Stands in for a frequency diagnostic of an input that comes on demand."""

    def tick(self):
        pass


class _Goal(object):
    """Cancellation flag of one running goal."""

    def __init__(self):
        self.cancelled = threading.Event()


class ImageProcessingNode(object):
    """See module docstring."""

    def __init__(self):
        self.target_frame = rospy.get_param('~target_frame', names.BASE_FRAME)
        self.min_ripeness = float(rospy.get_param('~min_ripeness', 0.7))
        self.fresh_data = bool(rospy.get_param('~fresh_data', True))
        self.data_timeout = float(rospy.get_param('~data_timeout', 5.0))
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
        self._goals = {}               # goal id -> _Goal, for image_processing
        self._scan_goal = None         # _Goal of the tomato_scan goal being served

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

    # -- set-up -------------------------------------------------------------------------------
    def _setup_diagnostics(self):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID('image_processing')
        self._freq = {}
        for topic, rate_param in ((names.RIGHT_RECT_COLOR, '~expected_rate'),
                                  (names.POINTS2, '~expected_rate'),
                                  (names.HAND_IMAGE, '~hand_expected_rate')):
            rate = float(rospy.get_param(rate_param, 10.0))
            if rate <= 0.0:          # triggered camera: frames come on demand, no rate to check
                self._freq[topic] = _NoRateCheck()
                continue
            bounds = {'min': rate * (1.0 - RATE_TOLERANCE), 'max': rate * (1.0 + RATE_TOLERANCE)}
            self._freq[topic] = diagnostic_updater.HeaderlessTopicDiagnostic(
                topic, self.updater, diagnostic_updater.FrequencyStatusParam(bounds, 0.1, 10))
        self._diag_timer = rospy.Timer(rospy.Duration(1.0), lambda _e: self.updater.update())

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

    # -- inputs -------------------------------------------------------------------------------
    def _on_stereo_pair(self, image, cloud):
        with self._cond:
            self._pair = (image, cloud)
            self._cond.notify_all()

    def _on_right_info(self, msg):
        with self._cond:
            self._right_info = msg

    def _on_hand_image(self, msg):
        self._freq[names.HAND_IMAGE].tick()
        with self._cond:
            self._hand_image = msg
            self._cond.notify_all()

    def _on_hand_info(self, msg):
        with self._cond:
            self._hand_info = msg

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

    def _hand_data(self, goal, since):
        def ready():
            msg = self._hand_image
            if msg is None or self._hand_info is None or msg.header.stamp < since:
                return None
            return msg, self._hand_info
        return self._wait(ready, goal, 'hand camera image on %s with camera_info'
                          % names.HAND_IMAGE, self.hand_trigger)

    # -- image_processing action --------------------------------------------------------------
    def _on_goal(self, handle):
        goal = handle.get_goal()
        gid = handle.get_goal_id().id
        state = _Goal()
        self._goals[gid] = state
        handle.set_accepted()
        arrival = rospy.get_rostime()
        worker = threading.Thread(target=self._serve, args=(handle, goal, state, gid, arrival),
                                  name='image_processing_goal')
        worker.daemon = True
        worker.start()

    def _on_cancel(self, handle):
        state = self._goals.get(handle.get_goal_id().id)
        if state is not None:
            state.cancelled.set()
            with self._cond:
                self._cond.notify_all()

    def _serve(self, handle, goal, state, gid, arrival):
        result = ImageProcessingResult()
        try:
            if goal.request == ImageProcessingGoal.SPATIAL_POSITIONING:
                result.tomatoes = self.spatial_positioning(goal.target_frame, goal.min_ripeness,
                                                           state, arrival)
                result.message = '%d tomatoes, %d pickable' % (
                    len(result.tomatoes.tomatoes),
                    sum(1 for t in result.tomatoes.tomatoes if t.pickable))
            elif goal.request == ImageProcessingGoal.SERVO_FEATURE:
                result.feature = self.servo_feature(goal.target_hint, state, arrival)
                result.message = 'target found' if result.feature.found else \
                    'no tomato in the hand camera image'
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
        state = _Goal()
        self._scan_goal = state
        worker = threading.Thread(target=self._serve_scan,
                                  args=(goal, state, rospy.get_rostime()), name='tomato_scan')
        worker.daemon = True
        worker.start()

    def _on_scan_preempt(self):
        if self._scan_goal is not None:
            self._scan_goal.cancelled.set()
            with self._cond:
                self._cond.notify_all()

    def _serve_scan(self, goal, state, arrival):
        result = TomatoScanResult()
        try:
            result.tomatoes = self.spatial_positioning(goal.target_frame, 0.0, state, arrival)
            result.pickable_count = sum(1 for t in result.tomatoes.tomatoes if t.pickable)
            result.success = True
            result.message = 'picking point %d: %d tomatoes, %d pickable' % (
                goal.picking_point, len(result.tomatoes.tomatoes), result.pickable_count)
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

    # -- the two requests ---------------------------------------------------------------------
    def spatial_positioning(self, target_frame, min_ripeness, state, arrival):
        """TomatoArray for the next stereo pair (see module docstring)."""
        if isinstance(min_ripeness, float) and math.isnan(min_ripeness):
            raise Aborted('min_ripeness is NaN')
        if min_ripeness > 1.0:
            raise Aborted('min_ripeness %.3f is above 1 (scores are 0..1)' % min_ripeness)
        threshold = min_ripeness if min_ripeness > 0.0 else self.min_ripeness
        frame = target_frame or self.target_frame
        since = arrival if self.fresh_data else rospy.Time(0)
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
            plausible = (loc is not None and self.min_fruit_radius <= loc.radius <= self.max_fruit_radius
                         and ordering.inside_image(det.u, det.v, det.radius_px, image_msg.width,
                                                   image_msg.height, self.border_margin_px))
            if loc is not None and not plausible:
                rospy.logdebug('image_processing: detection at (%.0f, %.0f) px, radius %.1f mm, not '
                               'pickable: cut by the image border or not a tomato\'s size', det.u, det.v,
                               loc.radius * 1000.0)
            entries.append((det, loc, point, point is not None and plausible and det.score >= threshold))
        pickable = [i for i, e in enumerate(entries) if e[3]]
        order = ordering.picking_order([(entries[i][0].u, entries[i][0].v) for i in pickable],
                                       self.row_tolerance)
        ordered = [pickable[k] for k in order]
        rest = sorted((i for i, e in enumerate(entries) if not e[3]),
                      key=lambda i: -entries[i][0].score)
        array = TomatoArray()
        array.header = image_msg.header
        array.image_id = _stamp_id(image_msg.header.stamp)
        width, height = image_msg.width, image_msg.height
        for rank, index in enumerate(ordered + rest):
            det, loc, point, is_pickable = entries[index]
            tomato = Tomato()
            tomato.id = rank
            x, y, w, h = det.box(width, height)
            tomato.box.x_offset, tomato.box.y_offset = x, y
            tomato.box.width, tomato.box.height = w, h
            if point is not None:
                tomato.pick_point = point
                tomato.radius = loc.radius
            else:
                tomato.pick_point.header.frame_id = frame
                tomato.pick_point.header.stamp = cloud_msg.header.stamp
                tomato.pick_point.point.x = float('nan')
                tomato.pick_point.point.y = float('nan')
                tomato.pick_point.point.z = float('nan')
            tomato.ripeness_stage = det.stage
            tomato.ripeness_score = det.score
            tomato.pickable = is_pickable
            tomato.pick_order = rank if is_pickable else -1
            array.tomatoes.append(tomato)
        self._publish_visuals(array, [entries[i][0] for i in ordered + rest], image_msg, frame)
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
        found = [(det, localisation.locate(cloud, det, info.P, image=bgr)) for det in detections]
        with self._cache_lock:
            self._cache = (stamp, found)
        return found

    def servo_feature(self, hint, state, arrival):
        """ServoFeature of the tomato nearest to the hint's projection in the hand camera."""
        since = arrival if self.fresh_data else rospy.Time(0)
        image_msg, info = self._hand_data(state, since)
        try:
            bgr = self.bridge.imgmsg_to_cv2(image_msg, 'bgr8')
        except CvBridgeError as exc:
            raise Aborted('cannot convert %s: %s' % (names.HAND_IMAGE, exc))
        k = np.array(info.K, dtype=np.float64).reshape(3, 3)
        dist = np.array(info.D, dtype=np.float64) if len(info.D) else np.zeros(5)
        if k[0, 0] <= 0.0:
            raise Aborted('%s has no intrinsics (K is zero)' % names.HAND_CAMERA_INFO)
        feature = ServoFeature()
        feature.header = image_msg.header
        detections = self.hand_detector.detect(bgr)
        hint_cam = None
        if hint.header.frame_id:
            values = (hint.point.x, hint.point.y, hint.point.z)
            if not all(math.isfinite(v) for v in values):
                raise Aborted('target_hint has a non-finite coordinate')
            query = PointStamped()
            query.header.frame_id = hint.header.frame_id
            query.header.stamp = image_msg.header.stamp
            query.point = hint.point
            try:
                hint_cam = self.tf_buffer.transform(query, image_msg.header.frame_id,
                                                    rospy.Duration(self.tf_timeout))
            except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                    tf2_ros.ExtrapolationException) as exc:
                raise Aborted('cannot transform target_hint from %s to %s: %s'
                              % (hint.header.frame_id, image_msg.header.frame_id, exc))
        if not detections:
            return feature
        centres = [self._undistorted_centre(d, k, dist) for d in detections]
        if hint_cam is not None and hint_cam.point.z > 0.0:
            p = np.array([hint_cam.point.x, hint_cam.point.y, hint_cam.point.z])
            ref, _ = cv2.projectPoints(p.reshape(1, 1, 3), np.zeros(3), np.zeros(3), k, dist)
            ref = ref.reshape(2)
            feature.depth = float(hint_cam.point.z)
        else:
            ref = np.array([k[0, 2], k[1, 2]])
        # with a hint the target's centre must lie on the fruit followed (not a neighbour)
        best = ordering.servo_target([c[:2] for c in centres],
                                     [d.radius_px for d in detections], ref,
                                     on_fruit=hint_cam is not None)
        if best is None:
            rospy.logwarn_throttle(2.0, 'image_processing: no fruit in the hand image holds the '
                                   'target\'s projection (%.0f, %.0f); %d others seen'
                                   % (ref[0], ref[1], len(detections)))
            return feature
        u, v, x, y = centres[best]
        feature.found = True
        feature.u, feature.v, feature.x, feature.y = u, v, x, y
        feature.diameter_px = 2.0 * detections[best].radius_px
        return feature

    @staticmethod
    def _undistorted_centre(det, k, dist):
        """(u, v, x, y): projection of the sphere centre (not the silhouette centre)."""
        pts = cv2.undistortPoints(np.array([[[det.u, det.v]]], dtype=np.float64), k, dist)
        x, y = pts.reshape(2)
        fx, fy = k[0, 0], k[1, 1]
        axis, _ = localisation.sphere_ray(x * fx, y * fy, det.radius_px, fx, fy, 0.0, 0.0)
        xn, yn = axis[0] / axis[2], axis[1] / axis[2]
        proj, _ = cv2.projectPoints(np.array([[[xn, yn, 1.0]]]), np.zeros(3), np.zeros(3), k,
                                    dist)
        u, v = proj.reshape(2)
        return float(u), float(v), float(xn), float(yn)

    # -- visual outputs -----------------------------------------------------------------------
    def _publish_visuals(self, array, detections, image_msg, frame):
        if self.image_pub.get_num_connections() > 0:
            bgr = self.bridge.imgmsg_to_cv2(image_msg, 'bgr8')
            drawn = annotate.annotate(bgr, [(d, t.pick_order)
                                            for d, t in zip(detections, array.tomatoes)])
            out = self.bridge.cv2_to_imgmsg(drawn, 'bgr8')
            out.header = image_msg.header
            self.image_pub.publish(out)
        markers = MarkerArray()
        clear = Marker()
        clear.action = Marker.DELETEALL
        markers.markers.append(clear)
        for tomato in array.tomatoes:
            if not math.isfinite(tomato.pick_point.point.x):
                continue
            r, g, b = annotate.STAGE_RGB[tomato.ripeness_stage]
            sphere = Marker()
            sphere.header.frame_id = frame
            sphere.header.stamp = array.header.stamp
            sphere.ns = 'tomatoes'
            sphere.id = tomato.id
            sphere.type = Marker.SPHERE
            sphere.action = Marker.ADD
            sphere.pose.position = tomato.pick_point.point
            sphere.pose.orientation.w = 1.0
            sphere.scale.x = sphere.scale.y = sphere.scale.z = 2.0 * max(tomato.radius, 0.005)
            sphere.color.r, sphere.color.g, sphere.color.b, sphere.color.a = r, g, b, 0.9
            markers.markers.append(sphere)
            text = Marker()
            text.header = sphere.header
            text.ns = 'pick_order'
            text.id = tomato.id
            text.type = Marker.TEXT_VIEW_FACING
            text.action = Marker.ADD
            text.pose.position.x = tomato.pick_point.point.x
            text.pose.position.y = tomato.pick_point.point.y
            text.pose.position.z = tomato.pick_point.point.z + tomato.radius + 0.02
            text.pose.orientation.w = 1.0
            text.scale.z = 0.03
            text.color.r = text.color.g = text.color.b = text.color.a = 1.0
            text.text = ('#%d' % (tomato.pick_order + 1)) if tomato.pickable else \
                '%.2f' % tomato.ripeness_score
            markers.markers.append(text)
        self.marker_pub.publish(markers)
