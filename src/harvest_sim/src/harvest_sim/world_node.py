"""ROS glue of the simulated world (node ``sim_world``, run in namespace ``sim``).

Owns the ground truth (harvest_sim.world.World) of the scenario and publishes it under /sim only.

Subscriptions (relative; the node runs in namespace ``sim``):
  joint_states (sensor_msgs/JointState)  ground-truth joints from the simulated controller
  suction_valve (harvest_sim/SuctionValve) suction valve open/closed, stamped when it changed
                                         (unstamped: when it arrives)
  shear_cut (std_msgs/Header)            one per shear close (judged once a joint state
                                         stamped at or after it has come, or after 0.5 s:
                                         World.shear_cut)
Publications:
  suction_sealed (std_msgs/Bool, latched)        true while the suction holds a fruit
  fruits (harvest_sim/SimFruitArray, latched)    every fruit, on change and at ~publish_rate
  camera_silence (harvest_sim/CameraSilence, latched)  the camera_silence fault, to sim_camera
Services:
  get_summary (harvest_sim/GetSimSummary)        counts by state
  ~vacuum_loss (std_srvs/Trigger)                fault: the held fruit drops off the suction
                                                 sleeve (World.lose_vacuum); suction_sealed
                                                 goes false, so the controller reads no vacuum
  ~camera_silence (harvest_sim/SilenceCamera)    fault: camera stereo, hand or all publishes
                                                 nothing (and holds no clock) for `duration` s
                                                 of ROS time
Parameters:
  ~scenario (required): scenario name (scenarios/NAME.yaml) or file path
  ~robot_config: robot.yaml path (default harvest_description/config/robot.yaml); a bad file
    (harvest_description.robot_config) ends the node at start: one fatal line, exit code 1
  ~seal_tolerance (0.012 m), ~cut_tolerance (0.010 m), ~tear_distance (0.12 m),
  ~publish_rate (10 Hz, ROS time), ~motion_rate (30 Hz: most often a moving held fruit is
  republished; state changes are published at once)
Sets /track/picking_points (the track layout a real robot reads from its site config).
"""

import os
import threading

import rospkg
import rospy
from geometry_msgs.msg import Point
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Header
from std_srvs.srv import Trigger, TriggerResponse

from harvest_sim import names
from harvest_sim import scenario as scn
from harvest_sim.frame_timing import ALL_CAMERAS, CAMERA_NAMES
from harvest_sim.msg import CameraSilence, SimFruit, SimFruitArray, SuctionValve
from harvest_sim.srv import (GetSimSummary, GetSimSummaryResponse, SilenceCamera,
                             SilenceCameraResponse)
from harvest_sim.world import World
from motion_pkg.kinematics import RobotGeometry
from harvest_description import robot_config


#: s of ROS time a stamped shear close waits for a joint state as recent as itself
CUT_WAIT = 0.5


def default_robot_config():
    return os.path.join(rospkg.RosPack().get_path('harvest_description'), 'config', 'robot.yaml')


def load_robot_config():
    """Validated robot.yaml from ~robot_config; a bad file: one fatal line, exit code 1."""
    return robot_config.load_or_exit(rospy.get_param('~robot_config', '') or
                                     default_robot_config(), rospy.logfatal)


def scenarios_dir():
    return os.path.join(rospkg.RosPack().get_path('harvest_sim'), 'scenarios')


def load_scenario_param():
    """Scenario from ~scenario; logs an actionable message and raises if it is missing/bad."""
    value = rospy.get_param('~scenario', '')
    if not value:
        msg = ('~scenario is required: a name from harvest_sim/scenarios (e.g. default, '
               'three_targets) or a scenario file path')
        rospy.logfatal(msg)
        raise rospy.ROSInitException(msg)
    path = scn.resolve_scenario(value, scenarios_dir())
    try:
        return scn.load_scenario(path)
    except scn.ScenarioError as e:
        rospy.logfatal('bad scenario: %s', e)
        raise rospy.ROSInitException(str(e))


def _point(v):
    return Point(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def fruit_array(world, stamp):
    """SimFruitArray of the world's current state."""
    msg = SimFruitArray()
    msg.header.stamp = stamp
    msg.header.frame_id = 'map'
    msg.scenario = world.scenario.name
    for f in world.fruits:
        s = f.fruit
        m = SimFruit(id=f.id, state=f.state, state_name=f.state_name,
                     position=_point(f.position), peduncle=_point(f.peduncle),
                     pedicel_top=_point(s.pedicel_top),
                     cut_point=_point(f.cut_point if f.cut_point is not None else f.peduncle),
                     radius=s.radius, ripeness=s.ripeness, ripe=s.ripe,
                     reachable=s.reachable, picking_point=s.picking_point,
                     attached=f.attached, held=f is world.held, cluster=s.cluster,
                     truss=s.truss)
        if f is world.held:
            m.hold_offset = _point(world.hold_offset)
        msg.fruits.append(m)
    return msg


class SimWorldNode(object):
    def __init__(self):
        scenario = load_scenario_param()
        geom = RobotGeometry(load_robot_config())
        self.world = World(scenario, geom,
                           rospy.get_param('~seal_tolerance', 0.012),
                           rospy.get_param('~cut_tolerance', 0.010),
                           rospy.get_param('~tear_distance', 0.12))
        self._lock = threading.Lock()
        self._published_version = -1
        self._published_state = -1
        self._last_pub = rospy.Time(0)
        self._motion_period = rospy.Duration(1.0 / float(rospy.get_param('~motion_rate', 30.0)))
        self._sealed = None
        rospy.set_param(names.PICKING_POINTS_PARAM, list(scenario.track.picking_points))
        self.sealed_pub = rospy.Publisher(names.SUCTION_SEALED, Bool, queue_size=1, latch=True)
        self.fruits_pub = rospy.Publisher(names.FRUITS, SimFruitArray, queue_size=1, latch=True)
        self._publish(force=True)
        self.silence_pub = rospy.Publisher(names.CAMERA_SILENCE, CameraSilence, queue_size=5,
                                           latch=True)
        rospy.Service(names.GET_SUMMARY, GetSimSummary, self._summary)
        rospy.Service('~vacuum_loss', Trigger, self._on_vacuum_loss)
        rospy.Service('~camera_silence', SilenceCamera, self._on_camera_silence)
        rospy.Subscriber(names.JOINT_STATES, JointState, self._on_joints, queue_size=5)
        rospy.Subscriber(names.SUCTION_VALVE, SuctionValve, self._on_valve, queue_size=5)
        rospy.Subscriber(names.SHEAR_CUT, Header, self._on_cut, queue_size=5)
        rate = float(rospy.get_param('~publish_rate', 10.0))
        self._timer = rospy.Timer(rospy.Duration(1.0 / rate), self._on_timer)
        rospy.loginfo('sim_world: scenario %s (%s), %d fruit, %d picking points',
                      scenario.name, scenario.source, len(scenario.fruits),
                      len(scenario.track.picking_points))

    def _log(self, events):
        for e in events:
            rospy.loginfo('sim_world: %s', e)

    def _on_joints(self, msg):
        joints = dict(zip(msg.name, msg.position))
        stamp = msg.header.stamp.to_sec() if not msg.header.stamp.is_zero() else None
        with self._lock:
            self._log(self.world.set_joints(joints, stamp))
        self._publish()

    def _on_valve(self, msg):
        # the controller's stamp (when the valve changed) orders it among the joint states:
        # only those stamped since an opening can seal the cup, and a closing stamped before
        # the joint state that tore the held fruit off lets it go still on its pedicel;
        # unstamped, it counts from its arrival
        stamp = msg.header.stamp.to_sec() if not msg.header.stamp.is_zero() else rospy.get_time()
        with self._lock:
            self._log(self.world.set_valve(msg.open, stamp))
        self._publish()

    def _on_cut(self, msg):
        stamp = msg.stamp.to_sec() if not msg.stamp.is_zero() else None
        with self._lock:
            self._log(self.world.shear_cut(stamp))
        self._publish()

    def _on_timer(self, _event):
        with self._lock:
            self._log(self.world.flush_cuts(rospy.get_time(), CUT_WAIT))
        self._publish(force=True)

    def _publish(self, force=False):
        now = rospy.Time.now()
        with self._lock:
            w = self.world
            sealed = w.sealed
            moved = w.version != self._published_version
            due = (w.state_version != self._published_state or force or
                   (moved and (now - self._last_pub >= self._motion_period or
                               now < self._last_pub)))
            msg = fruit_array(w, now) if due else None
            if due:
                self._published_version, self._published_state = w.version, w.state_version
                self._last_pub = now
            if sealed != self._sealed:
                # published under the lock: several threads publish (joint states, the valve,
                # the timer), and a seal sent after the release that followed it would leave
                # the controller reading vacuum on an empty cup
                self._sealed = sealed
                self.sealed_pub.publish(Bool(data=sealed))
        if msg is not None:
            self.fruits_pub.publish(msg)

    def _on_vacuum_loss(self, _req):
        with self._lock:
            events = self.world.lose_vacuum()
        for e in events:
            rospy.logwarn('sim_world: injected fault: %s', e)
        self._publish()
        return TriggerResponse(success=True, message='; '.join(events))

    def _on_camera_silence(self, req):
        if req.camera not in CAMERA_NAMES + (ALL_CAMERAS,):
            return SilenceCameraResponse(success=False, message='unknown camera %r (%s)' % (
                req.camera, ', '.join(CAMERA_NAMES + (ALL_CAMERAS,))))
        if not req.duration >= 0.0:
            return SilenceCameraResponse(success=False, message='duration must be >= 0 s')
        now = rospy.Time.now()
        until = now + rospy.Duration.from_sec(req.duration) if req.duration > 0.0 \
            else rospy.Time(0)
        self.silence_pub.publish(CameraSilence(camera=req.camera, until=until))
        text = ('camera %s silent for %.3f s, until %.3f' % (req.camera, req.duration,
                                                            until.to_sec())
                if req.duration > 0.0 else 'camera %s: silence ended' % req.camera)
        rospy.logwarn('sim_world: injected fault: %s', text)
        return SilenceCameraResponse(success=True, message=text)

    def _summary(self, _req):
        with self._lock:
            c = self.world.summary()
        r = GetSimSummaryResponse(scenario=self.world.scenario.name)
        for key in ('total', 'ripe', 'ripe_reachable', 'hanging', 'held', 'harvested',
                    'collected', 'collected_ripe', 'collected_unripe', 'dropped', 'damaged',
                    'seal_events', 'cut_events'):
            setattr(r, key, c[key])
        return r
