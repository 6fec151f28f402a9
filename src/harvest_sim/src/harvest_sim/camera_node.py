"""ROS glue of the simulated cameras (node ``sim_camera``; one instance per camera head).

~kind "stereo": the Bumblebee2-like head. Publishes bumblebee2/left/image_raw,
bumblebee2/right/image_raw (bgr8) and bumblebee2/{left,right}/camera_info (plumb_bob, zero
distortion, the right P has Tx = -fx * baseline), all four with one stamp (stereo_image_proc's
exact sync). The right eye is rendered from stereo_right_optical, but both eyes' headers carry
frame stereo_left_optical (~right_frame_id): a stereo pair is described in the left camera's
frame (the right P holds the baseline), and image_geometry's StereoCameraModel, used by
stereo_image_proc, asserts that both camera_info frames are equal.
~kind "hand": the eye-in-hand camera on the cutting hand: hand_camera/image_raw and
hand_camera/camera_info in frame hand_camera_optical.

A held fruit is drawn where the frame's joint state puts the suction tcp (its hold offset comes
with /sim/fruits), so it never lags the arm that moves it.
Subscriptions: joint_states (remap to /sim/joint_states), fruits (remap to /sim/fruits),
bumblebee2/image_trigger or hand_camera/image_trigger (std_msgs/Empty, ~triggered only).
Publications: the images and camera_info above; sim/clock_hold (harvest_sim/ClockHold).
The image shows the scene at the latest joint state and carries that joint state's stamp (not
the time it is sent: harvest_sim.frame_timing); a frame is rendered only when the camera pose or
the fruit changed, otherwise the cached frame goes out again with the newer joint state's stamp,
and nothing goes out without a newer joint state. Nothing is rendered or published while nobody
subscribes (~always_publish false).

Free-running (default): one frame every 1/~rate of ROS time. Triggered (~triggered true, like a
camera with a software trigger, or Gazebo's triggered camera): one frame per message on
image_trigger, showing the robot at the first joint state stamped at or after the trigger's
arrival and stamped with that joint state's time, so a frame asked for after a move shows the
robot where it stopped. Nothing else is rendered. Triggers that come before that frame is out
share it.

Clock holds (~hold_clock, default true): the camera holds sim_clock (sim/clock_hold) until it
has delivered what is due: a free-running camera with subscribers at its next frame's time, a
triggered camera from the trigger until its frame is out. Rendering therefore takes no simulated
time and the frames keep their simulated rate on a loaded machine.

Silence (the camera_silence fault of sim_world, on sim/camera_silence, harvest_sim/CameraSilence
naming the camera's ~kind or "all"): until its end (ROS time) the camera publishes nothing,
drops its triggers and holds no clock: a pending hold is released at once, so the clock runs on
and the silence ends (harvest_sim.frame_timing.CameraSilence).

Parameters: ~scenario (required, name or path), ~kind (stereo|hand), ~rate (Hz of ROS time:
stereo 2, hand 5), ~width, ~height, ~hfov_deg (defaults 1024x768/66 deg and 640x480/60 deg),
~noise_sigma (2.0 DN), ~seed (default: the scenario's), ~robot_config, ~always_publish (false),
~right_frame_id (stereo_left_optical), ~triggered (false), ~hold_clock (true),
~pose_wait_wall (1.0 wall seconds: a triggered camera holding the clock for a joint state at the
trigger's time lets it run on after this long).
"""

import threading
import time

import numpy as np
import rospy
from sensor_msgs.msg import CameraInfo, Image, JointState
from std_msgs.msg import Empty

from harvest_sim import camera_model, names, render
from harvest_sim.frame_timing import CameraSilence, frame_stamp, next_frame_hold
from harvest_sim.msg import CameraSilence as CameraSilenceMsg
from harvest_sim.msg import ClockHold, SimFruitArray
from harvest_sim.world_node import load_robot_config, load_scenario_param
from motion_pkg.kinematics import RobotGeometry

KINDS = {
    'stereo': dict(width=camera_model.STEREO_WIDTH, height=camera_model.STEREO_HEIGHT,
                   hfov_deg=camera_model.STEREO_HFOV_DEG, rate=2.0),
    'hand': dict(width=camera_model.HAND_WIDTH, height=camera_model.HAND_HEIGHT,
                 hfov_deg=camera_model.HAND_HFOV_DEG, rate=5.0),
}
#: frame the held fruit moves with (harvest_sim.world: rigidly, translation only)
SUCTION_TCP = 'right_suction_tcp'
#: joints that move each camera (a change re-renders)
POSE_JOINTS = {'stereo': ('cart_joint', 'waist_joint'),
               'hand': ('cart_joint', 'waist_joint', 'left_lift_joint', 'left_boom_joint',
                        'left_forearm_joint')}


def camera_info(camera, frame_id, tx=0.0):
    info = CameraInfo()
    info.header.frame_id = frame_id
    info.width, info.height = camera.width, camera.height
    info.distortion_model = 'plumb_bob'
    info.D = [0.0] * 5
    info.K = camera.K.flatten().tolist()
    info.R = np.eye(3).flatten().tolist()
    info.P = camera.P(tx).flatten().tolist()
    return info


def image_msg(img, frame_id):
    msg = Image()
    msg.header.frame_id = frame_id
    msg.height, msg.width = img.shape[:2]
    msg.encoding = 'bgr8'
    msg.is_bigendian = 0
    msg.step = img.shape[1] * 3
    msg.data = img.tobytes()
    return msg


class Eye(object):
    """One image stream: camera model, frame, publishers, cached message."""

    def __init__(self, name, camera, frame, image_topic, info_topic, tx=0.0, header_frame=None):
        self.name, self.camera, self.frame = name, camera, frame     # frame: pose to render
        self.header_frame = header_frame or frame
        self.info = camera_info(camera, self.header_frame, tx)
        self.image_pub = rospy.Publisher(image_topic, Image, queue_size=1)
        self.info_pub = rospy.Publisher(info_topic, CameraInfo, queue_size=1)
        self.image = None
        self.frames = 0

    def wanted(self):
        return self.image_pub.get_num_connections() > 0 or self.info_pub.get_num_connections() > 0


class ClockHolder(object):
    """This node's hold on sim_clock (sim/clock_hold); a no-op when disabled."""

    def __init__(self, enabled):
        self._pub = rospy.Publisher(names.CLOCK_HOLD, ClockHold, queue_size=20,
                                    tcp_nodelay=True) if enabled else None
        self._msg = ClockHold(holder=rospy.get_name())
        self._until = None

    def hold(self, until):
        """Let the clock run until it reaches `until` (rospy.Time); None or zero releases."""
        if self._pub is None:
            return
        until = until if until is not None else rospy.Time(0)
        if until == self._until:
            return
        self._until = until
        self._msg.until = until
        try:
            self._pub.publish(self._msg)
        except rospy.ROSException:        # shutting down
            pass


class SimCameraNode(object):
    def __init__(self):
        self.scenario = load_scenario_param()
        self.kind = rospy.get_param('~kind', 'stereo')
        if self.kind not in KINDS:
            msg = '~kind must be one of %s, got %r' % (', '.join(KINDS), self.kind)
            rospy.logfatal(msg)
            raise rospy.ROSInitException(msg)
        d = KINDS[self.kind]
        camera = camera_model.PinholeCamera.from_hfov(rospy.get_param('~width', d['width']),
                                                      rospy.get_param('~height', d['height']),
                                                      rospy.get_param('~hfov_deg', d['hfov_deg']))
        self.geom = RobotGeometry(load_robot_config())
        seed = rospy.get_param('~seed', self.scenario.seed)
        self.renderer = render.Renderer(self.scenario, seed,
                                        noise_sigma=rospy.get_param('~noise_sigma', 2.0))
        self.always = rospy.get_param('~always_publish', False)
        self.triggered = bool(rospy.get_param('~triggered', False))
        self.pose_wait_wall = float(rospy.get_param('~pose_wait_wall', 1.0))
        self.holder = ClockHolder(bool(rospy.get_param('~hold_clock', True)))
        if self.kind == 'stereo':
            self.eyes = [Eye('left', camera, 'stereo_left_optical', names.STEREO_LEFT_IMAGE,
                             names.STEREO_LEFT_INFO),
                         Eye('right', camera, 'stereo_right_optical', names.STEREO_RIGHT_IMAGE,
                             names.STEREO_RIGHT_INFO, -camera.fx * self.geom.stereo_baseline,
                             rospy.get_param('~right_frame_id', 'stereo_left_optical'))]
        else:
            self.eyes = [Eye('hand', camera, 'hand_camera_optical', names.HAND_IMAGE,
                             names.HAND_INFO)]
        self._lock = threading.Lock()
        self._render_lock = threading.RLock()     # one frame (and hold) at a time
        self._joints = {}
        self._joints_stamp = None
        self._fruits = [(f, None) for f in render.fruits_from_scenario(self.scenario)]
        self._rendered_key = None
        self._last_stamp = None       # stamp of the last frame sent
        self._trigger = None          # ROS time of the latest trigger not served yet
        self._generation = 0          # counts trigger rounds (a stale fallback timer is ignored)
        rospy.Subscriber(names.JOINT_STATES, JointState, self._on_joints, queue_size=1)
        rospy.Subscriber(names.FRUITS, SimFruitArray, self._on_fruits, queue_size=1)
        self.silence = CameraSilence(self.kind)
        rospy.Subscriber(names.CAMERA_SILENCE_ROOT, CameraSilenceMsg, self._on_silence,
                         queue_size=5)
        rate = float(rospy.get_param('~rate', d['rate']))
        if self.triggered:
            rospy.Subscriber(names.STEREO_TRIGGER if self.kind == 'stereo' else
                             names.HAND_TRIGGER, Empty, self._on_trigger, queue_size=10,
                             tcp_nodelay=True)
            self._timer = None
        else:
            self._period = rospy.Duration(1.0 / rate)
            self._timer = rospy.Timer(self._period, self._on_timer)
        rospy.loginfo('sim_camera: %s camera %dx%d, %.1f deg HFOV, %s', self.kind,
                      camera.width, camera.height, camera.hfov_deg(),
                      'triggered' if self.triggered else '%.1f Hz' % rate)

    def _wanted(self):
        return self.always or any(e.wanted() for e in self.eyes)

    # -- inputs ---------------------------------------------------------------------------
    def _on_joints(self, msg):
        with self._lock:
            self._joints.update(zip(msg.name, msg.position))
            self._joints_stamp = msg.header.stamp
            trigger = self._trigger
        if trigger is not None and msg.header.stamp >= trigger:
            self._serve_trigger()

    def _on_fruits(self, msg):
        index = dict((f.id, i) for i, f in enumerate(self.scenario.fruits))
        fruits = []
        for m in msg.fruits:
            i = index.get(m.id)
            if i is None or m.state == m.COLLECTED:
                continue          # collected fruit lie in the box, out of every view
            p = (m.position.x, m.position.y, m.position.z)
            cut = None if m.attached else np.array([m.cut_point.x, m.cut_point.y, m.cut_point.z])
            # a held fruit follows the suction tcp: drawn where the frame's joint state puts it
            offset = np.array([m.hold_offset.x, m.hold_offset.y, m.hold_offset.z]) \
                if m.held else None
            fruits.append((render.RenderFruit(i, np.array(p), m.radius, m.ripeness,
                                              self.scenario.fruits[i].pedicel_top, m.attached,
                                              cut, m.held), offset))
        with self._lock:
            self._fruits = fruits

    def _on_silence(self, msg):
        until = None if msg.until.is_zero() else msg.until
        with self._render_lock:
            if not self.silence.set(msg.camera, until):
                return
            if self.silence.silent(rospy.Time.now()):
                rospy.logwarn('sim_camera: %s camera silent until %.3f (camera_silence fault)',
                              self.kind, until.to_sec())
                with self._lock:
                    self._trigger = None          # the pending frame never comes
                self.holder.hold(None)            # and the clock must not wait for it
            else:
                rospy.logwarn('sim_camera: %s camera publishes again', self.kind)

    # -- triggered ------------------------------------------------------------------------
    def _on_trigger(self, _msg):
        now = rospy.Time.now()
        if self.silence.silent(now):
            rospy.logwarn_throttle(5.0, 'sim_camera: %s camera silent (camera_silence fault): '
                                   'trigger dropped' % self.kind)
            return
        with self._render_lock:
            with self._lock:
                first = self._trigger is None
                # one frame serves every trigger that came before the pose it shows
                self._trigger = now if first else max(self._trigger, now)
                self._generation += first
                generation = self._generation
            # stop the clock here until a joint state at or after the trigger has come (the
            # simulated controller publishes one on every tick) and the frame is out
            self.holder.hold(now)
            if first:
                watchdog = threading.Timer(self.pose_wait_wall, self._pose_late, (generation,))
                watchdog.daemon = True
                watchdog.start()
            self._serve_trigger()

    def _pose_late(self, generation):
        """Wall-time watchdog: no joint state at or after the trigger has come while the clock
        stood still (the controller's rate is not a multiple of the tick rate, or no controller):
        let the clock run until one comes. The frame never shows an older pose as new."""
        with self._render_lock:
            with self._lock:
                pending = self._trigger is not None and generation == self._generation
            if pending:
                rospy.logwarn_throttle(10.0, 'sim_camera: no joint state at the trigger\'s time '
                                       'within %.1f wall seconds; the clock runs on until one '
                                       'comes' % self.pose_wait_wall)
                self.holder.hold(None)

    def _serve_trigger(self):
        """Render the frame a trigger asked for once a joint state stamped at or after the
        trigger is here; the frame carries that joint state's stamp."""
        with self._render_lock:
            with self._lock:
                trigger, stamp = self._trigger, self._joints_stamp
            if trigger is None or stamp is None or stamp < trigger:
                return
            if self.silence.silent(rospy.Time.now()):
                with self._lock:
                    self._trigger = None
                self.holder.hold(None)
                return
            self.holder.hold(rospy.Time.now())          # stop the clock while rendering
            try:
                if self._wanted():
                    self._frame()
            finally:                  # a failed render must not stop the world
                with self._lock:
                    self._trigger = None
                self.holder.hold(None)

    # -- free-running ---------------------------------------------------------------------
    def _on_timer(self, event):
        with self._render_lock:
            if not self._wanted():
                self.holder.hold(None)
                return
            now = rospy.Time.now()
            try:
                if not self.silence.silent(now):
                    self._frame()
            finally:
                # hold the clock at the next frame's time until that frame is out (not while
                # silent: nothing would come)
                self.holder.hold(self.silence.hold(
                    now, next_frame_hold(now, event.current_expected, self._period)))

    # -- one frame ------------------------------------------------------------------------
    def _frame(self):
        with self._lock:
            joints = dict(self._joints)
            joints_stamp = self._joints_stamp
            held_fruits = self._fruits
        if joints_stamp is not None and joints_stamp.is_zero():
            joints_stamp = None
        # the frame shows the robot at this joint state: it carries its time (frame_timing)
        stamp = frame_stamp(rospy.Time.now(), joints_stamp, self._last_stamp)
        if stamp is None:
            return
        poses = self.geom.frame_transforms(joints)
        tcp = poses[SUCTION_TCP]
        fruits = [f if offset is None else f._replace(position=tcp[:3, 3] + tcp[:3, :3].dot(offset))
                  for f, offset in held_fruits]
        fkey = tuple((f.index, round(f.position[0], 4), round(f.position[1], 4),
                      round(f.position[2], 4), f.attached) for f in fruits)
        key = (tuple(round(joints.get(j, 0.0), 5) for j in POSE_JOINTS[self.kind]), fkey)
        if key != self._rendered_key:
            for e in self.eyes:
                start = time.perf_counter()
                img = self.renderer.render(e.camera, poses[e.frame], fruits,
                                           noise_key=(e.name, e.frames))
                ms = (time.perf_counter() - start) * 1000.0
                rospy.logdebug_throttle(10.0, 'sim_camera: %s frame rendered in %.0f ms'
                                        % (e.name, ms))
                e.frames += 1
                e.image = image_msg(img, e.header_frame)
            self._rendered_key = key
        self._last_stamp = stamp
        for e in self.eyes:
            e.image.header.stamp = stamp
            e.info.header.stamp = stamp
            e.info_pub.publish(e.info)
            e.image_pub.publish(e.image)
