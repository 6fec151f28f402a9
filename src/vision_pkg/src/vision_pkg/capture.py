"""Image acquisition nodes of the vision module (section 3.5.1): ROS glue only.

DualEyeImageCapture (dual_eye_image_capture)
    ~source: 'relay' (default; 'simulated' is accepted for it) relays
        bumblebee2/{left,right}/{image_raw,camera_info} -> stereo/{left,right}/{image_raw,camera_info}
        (a simulator that publishes under bumblebee2/; vision.launch with stereo_source:=simulated
        starts no capture node: harvest_sim then publishes stereo/* itself, without this copy)
    'bumblebee2' grabs the real Bumblebee2 through the FlyCapture2 SDK Python bindings
    (PyCapture2) and publishes the same four topics with camera_info from calibration files.
    stereo_image_proc, run in namespace 'stereo', turns them into the paper's five images.
SingleEyeImageCapture (single_eye_image_capture)
    ~source: 'relay' (default; 'simulated' is accepted for it) relays
    hand_camera/{image_raw,camera_info} -> hand_eye/{image_raw,camera_info}; 'v4l2' opens a V4L2
    device with OpenCV and publishes
    hand_eye/image_raw plus hand_eye/camera_info from ~camera_info_url.
Both publish /diagnostics (output frame rates).
"""
import threading

import numpy as np
import rospy
import rospkg
import diagnostic_updater
from sensor_msgs.msg import CameraInfo, Image

from vision_pkg import calibration, names

#: rospy subscriber buffer for images (platform notes: the default one delivers stale frames)
IMAGE_BUFF_SIZE = 16 * 1024 * 1024
#: accepted output frame-rate band around the expected rate, as a fraction of it
RATE_TOLERANCE = 0.5
#: diagnostics publishing period [s]
DIAGNOSTIC_PERIOD = 1.0
#: ~source values that relay a simulator's topics
RELAY_SOURCES = ('relay', 'simulated')


def camera_info_from_calibration(calib, frame_id):
    """Fill a sensor_msgs/CameraInfo from a calibration.parse_calibration() dict."""
    info = CameraInfo()
    info.header.frame_id = frame_id
    info.width = calib['width']
    info.height = calib['height']
    info.distortion_model = calib['distortion_model']
    info.D = list(calib['D'])
    info.K = list(calib['K'])
    info.R = list(calib['R'])
    info.P = list(calib['P'])
    return info


def load_camera_info(url, frame_id, fallback_size, fallback_hfov):
    """camera_info from a camera_info_url, or an ideal pinhole (with a warning) when url is empty."""
    path = calibration.resolve_url(url, rospkg.RosPack().get_path)
    if not path:
        rospy.logwarn('no camera_info_url given: publishing an ideal %dx%d pinhole calibration '
                      '(%.0f deg HFOV) for %s', fallback_size[0], fallback_size[1],
                      np.degrees(fallback_hfov), frame_id)
        calib = calibration.default_calibration(fallback_size[0], fallback_size[1], fallback_hfov)
    else:
        calib = calibration.load_calibration(path)
    return camera_info_from_calibration(calib, frame_id)


def bgr_image_msg(frame, stamp, frame_id):
    """sensor_msgs/Image (bgr8 or mono8) from a numpy frame, without cv_bridge."""
    msg = Image()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = frame.shape[:2]
    if frame.ndim == 2:
        msg.encoding = 'mono8'
        msg.step = msg.width
    else:
        msg.encoding = 'bgr8'
        msg.step = msg.width * 3
    msg.is_bigendian = 0
    msg.data = np.ascontiguousarray(frame).tobytes()
    return msg


class RateDiagnostics(object):
    """diagnostic_updater wrapper: one frequency check per published topic."""

    def __init__(self, hardware_id, expected_rate):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(hardware_id)
        self._bounds = {'min': expected_rate * (1.0 - RATE_TOLERANCE),
                        'max': expected_rate * (1.0 + RATE_TOLERANCE)}
        self._checks = {}
        self._timer = rospy.Timer(rospy.Duration(DIAGNOSTIC_PERIOD), self._update)

    def add(self, topic):
        self._checks[topic] = diagnostic_updater.HeaderlessTopicDiagnostic(
            topic, self.updater,
            diagnostic_updater.FrequencyStatusParam(self._bounds, 0.1, 10))

    def tick(self, topic):
        self._checks[topic].tick()

    def add_status(self, name, function):
        self.updater.add(name, function)

    def _update(self, _event):
        self.updater.update()

    def shutdown(self):
        self._timer.shutdown()


class TopicRelay(object):
    """Republishes one topic under another name, optionally overriding header.frame_id."""

    def __init__(self, in_topic, out_topic, msg_type, frame_id='', diagnostics=None):
        self._frame_id = frame_id
        self._out_topic = out_topic
        self._diagnostics = diagnostics
        self._pub = rospy.Publisher(out_topic, msg_type, queue_size=1)
        if diagnostics is not None:
            diagnostics.add(out_topic)
        self._sub = rospy.Subscriber(in_topic, msg_type, self._callback, queue_size=1,
                                     buff_size=IMAGE_BUFF_SIZE, tcp_nodelay=True)

    def _callback(self, msg):
        if self._frame_id:
            msg.header.frame_id = self._frame_id
        self._pub.publish(msg)
        if self._diagnostics is not None:
            self._diagnostics.tick(self._out_topic)


def _fatal(message):
    rospy.logfatal(message)
    rospy.signal_shutdown(message)


class DualEyeImageCapture(object):
    """Bumblebee2 stereo head acquisition (see module docstring)."""

    def __init__(self):
        self.source = rospy.get_param('~source', 'relay')
        self.input_ns = rospy.get_param('~input_ns', names.BUMBLEBEE2_NS)
        self.output_ns = rospy.get_param('~output_ns', names.STEREO_NS)
        self.frame_ids = {'left': rospy.get_param('~left_frame_id', ''),
                          'right': rospy.get_param('~right_frame_id', '')}
        rate = float(rospy.get_param('~expected_rate', 10.0))
        self.diagnostics = RateDiagnostics('bumblebee2 (%s)' % self.source, rate)
        self.relays = []
        self.grabber = None
        if self.source in RELAY_SOURCES:
            for eye in names.EYES:
                for topic, msg_type in ((names.IMAGE_RAW, Image), (names.CAMERA_INFO, CameraInfo)):
                    self.relays.append(TopicRelay(
                        '%s/%s/%s' % (self.input_ns, eye, topic),
                        '%s/%s/%s' % (self.output_ns, eye, topic), msg_type,
                        self.frame_ids[eye],
                        self.diagnostics if topic == names.IMAGE_RAW else None))
            rospy.loginfo('dual_eye_image_capture: relaying %s/* to %s/*', self.input_ns,
                          self.output_ns)
        elif self.source == 'bumblebee2':
            self.grabber = Bumblebee2Grabber(self.output_ns, self.frame_ids, self.diagnostics)
        else:
            _fatal("dual_eye_image_capture: unknown ~source '%s' (use 'relay' or 'bumblebee2')"
                   % self.source)

    def shutdown(self):
        if self.grabber is not None:
            self.grabber.stop()
        self.diagnostics.shutdown()


class Bumblebee2Grabber(object):
    """Real Bumblebee2 through the FlyCapture2 SDK (PyCapture2). Untested without hardware.

    The BB2 streams both sensors pixel-interleaved in one 16-bit raw Bayer image; this splits
    and debayers them and publishes raw colour images with camera_info from the stereo
    calibration files (~left_camera_info_url, ~right_camera_info_url, e.g. exported from the
    Triclops factory calibration or made with camera_calibration). Rectification and
    matching are stereo_image_proc's job.
    """

    BAYER_CODES = {'BGGR': 'COLOR_BayerBG2BGR', 'RGGB': 'COLOR_BayerRG2BGR',
                   'GBRG': 'COLOR_BayerGB2BGR', 'GRBG': 'COLOR_BayerGR2BGR'}

    def __init__(self, output_ns, frame_ids, diagnostics):
        self._running = False
        try:
            import PyCapture2  # noqa: F401 vendor SDK, not packaged in Debian
        except ImportError:
            _fatal("dual_eye_image_capture: ~source 'bumblebee2' needs the FLIR FlyCapture2 SDK "
                   "and its Python bindings (module PyCapture2), which are not installed. Install "
                   "the vendor SDK, or run with source:=relay (a simulator).")
            return
        import cv2
        self._cv2 = cv2
        self._sdk = PyCapture2
        self._frame_ids = {eye: frame_ids[eye] or 'stereo_%s_optical' % eye for eye in names.EYES}
        pattern = rospy.get_param('~bayer_pattern', 'BGGR')
        if pattern not in self.BAYER_CODES:
            _fatal('dual_eye_image_capture: ~bayer_pattern must be one of %s'
                   % sorted(self.BAYER_CODES))
            return
        self._bayer = getattr(cv2, self.BAYER_CODES[pattern])
        self._right_first = bool(rospy.get_param('~right_image_first', True))
        self._diagnostics = diagnostics
        try:
            self._infos = {eye: load_camera_info(
                rospy.get_param('~%s_camera_info_url' % eye, ''), self._frame_ids[eye],
                (1024, 768), np.radians(66.0)) for eye in names.EYES}
        except calibration.CalibrationError as exc:
            _fatal('dual_eye_image_capture: %s' % exc)
            return
        bus = PyCapture2.BusManager()
        if bus.getNumOfCameras() < 1:
            _fatal('dual_eye_image_capture: the FlyCapture2 SDK finds no camera on the bus '
                   '(check the FireWire/USB cable and permissions)')
            return
        self._camera = PyCapture2.Camera()
        self._camera.connect(bus.getCameraFromIndex(int(rospy.get_param('~camera_index', 0))))
        self._camera.startCapture()
        self._pubs = {}
        for eye in names.EYES:
            image_topic = '%s/%s/%s' % (output_ns, eye, names.IMAGE_RAW)
            self._pubs[eye] = (rospy.Publisher(image_topic, Image, queue_size=1),
                               rospy.Publisher('%s/%s/%s' % (output_ns, eye, names.CAMERA_INFO),
                                               CameraInfo, queue_size=1))
            diagnostics.add(image_topic)
        self._running = True
        self._thread = threading.Thread(target=self._loop, name='bumblebee2')
        self._thread.daemon = True
        self._thread.start()
        rospy.loginfo('dual_eye_image_capture: Bumblebee2 capture started')

    def _loop(self):
        while self._running and not rospy.is_shutdown():
            try:
                buf = self._camera.retrieveBuffer()
            except self._sdk.Fc2error as exc:
                rospy.logwarn_throttle(5.0, 'Bumblebee2 retrieveBuffer failed: %s' % exc)
                continue
            stamp = rospy.Time.now()
            rows, cols = buf.getRows(), buf.getCols()
            raw = np.frombuffer(bytes(buf.getData()), dtype=np.uint8).reshape(rows, cols * 2)
            first, second = raw[:, 0::2], raw[:, 1::2]
            eyes = {'right': first, 'left': second} if self._right_first else \
                {'left': first, 'right': second}
            for eye in names.EYES:
                colour = self._cv2.cvtColor(np.ascontiguousarray(eyes[eye]), self._bayer)
                image_pub, info_pub = self._pubs[eye]
                info = self._infos[eye]
                info.header.stamp = stamp
                image_pub.publish(bgr_image_msg(colour, stamp, self._frame_ids[eye]))
                info_pub.publish(info)
                self._diagnostics.tick(image_pub.resolved_name)

    def stop(self):
        if self._running:
            self._running = False
            self._camera.stopCapture()
            self._camera.disconnect()


class SingleEyeImageCapture(object):
    """Eye-in-hand monocular camera acquisition (see module docstring)."""

    def __init__(self):
        self.source = rospy.get_param('~source', 'relay')
        self.input_ns = rospy.get_param('~input_ns', names.HAND_CAMERA_NS)
        self.output_ns = rospy.get_param('~output_ns', names.HAND_EYE_NS)
        self.frame_id = rospy.get_param('~frame_id', '')
        self.fps = float(rospy.get_param('~fps', 25.0))
        self.diagnostics = RateDiagnostics('hand camera (%s)' % self.source, self.fps)
        self.relays = []
        self.grabber = None
        if self.source in RELAY_SOURCES:
            for topic, msg_type in ((names.IMAGE_RAW, Image), (names.CAMERA_INFO, CameraInfo)):
                self.relays.append(TopicRelay(
                    '%s/%s' % (self.input_ns, topic), '%s/%s' % (self.output_ns, topic),
                    msg_type, self.frame_id,
                    self.diagnostics if topic == names.IMAGE_RAW else None))
            rospy.loginfo('single_eye_image_capture: relaying %s/* to %s/*', self.input_ns,
                          self.output_ns)
        elif self.source == 'v4l2':
            self.grabber = V4l2Grabber(self.output_ns, self.frame_id or names.HAND_OPTICAL_FRAME,
                                       self.fps, self.diagnostics)
        else:
            _fatal("single_eye_image_capture: unknown ~source '%s' (use 'relay' or 'v4l2')"
                   % self.source)

    def shutdown(self):
        if self.grabber is not None:
            self.grabber.stop()
        self.diagnostics.shutdown()


class V4l2Grabber(object):
    """OpenCV VideoCapture on a V4L2 device; camera_info from ~camera_info_url."""

    def __init__(self, output_ns, frame_id, fps, diagnostics):
        import cv2
        self._running = False
        device = rospy.get_param('~device', '/dev/video0')
        width = int(rospy.get_param('~width', 640))
        height = int(rospy.get_param('~height', 480))
        try:
            self.info = load_camera_info(rospy.get_param('~camera_info_url', ''), frame_id,
                                         (width, height), np.radians(float(
                                             rospy.get_param('~hfov_deg', 60.0))))
        except calibration.CalibrationError as exc:
            _fatal('single_eye_image_capture: %s' % exc)
            return
        if (self.info.width, self.info.height) != (width, height):
            rospy.logwarn('single_eye_image_capture: calibration is %dx%d but capture is %dx%d',
                          self.info.width, self.info.height, width, height)
        index = int(device) if str(device).isdigit() else device
        self._cap = cv2.VideoCapture(index, cv2.CAP_V4L2)
        if not self._cap.isOpened():
            _fatal('single_eye_image_capture: cannot open V4L2 device %s (absent, busy or no '
                   'permission); check ~device or run with source:=relay (a simulator)' % device)
            return
        self._cap.set(cv2.CAP_PROP_FRAME_WIDTH, width)
        self._cap.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        self._cap.set(cv2.CAP_PROP_FPS, fps)
        self._frame_id = frame_id
        self._diagnostics = diagnostics
        self._image_topic = '%s/%s' % (output_ns, names.IMAGE_RAW)
        self._image_pub = rospy.Publisher(self._image_topic, Image, queue_size=1)
        self._info_pub = rospy.Publisher('%s/%s' % (output_ns, names.CAMERA_INFO), CameraInfo,
                                         queue_size=1)
        diagnostics.add(self._image_topic)
        self._running = True
        self._thread = threading.Thread(target=self._loop, name='v4l2')
        self._thread.daemon = True
        self._thread.start()
        rospy.loginfo('single_eye_image_capture: capturing from %s at %dx%d', device, width,
                      height)

    def _loop(self):
        while self._running and not rospy.is_shutdown():
            ok, frame = self._cap.read()   # blocks until the device delivers a frame
            if not ok:
                rospy.logwarn_throttle(5.0, 'single_eye_image_capture: frame grab failed')
                continue
            stamp = rospy.Time.now()
            self.info.header.stamp = stamp
            self._image_pub.publish(bgr_image_msg(frame, stamp, self._frame_id))
            self._info_pub.publish(self.info)
            self._diagnostics.tick(self._image_topic)

    def stop(self):
        if self._running:
            self._running = False
            self._thread.join(1.0)
            self._cap.release()
