#!/usr/bin/env python3
"""A mission after a day of observations visits only the picking points of the farm server's plan.

The test owns a real farm server process (harvest_test_utils.farm, embedded SQLite in a temp
dir, on the loopback port ~farm_port, this robot's token from ~token_file). It uploads "yesterday's" scan of
the row through network_pkg's own outbox and client: the scenario's fruit at their true map
positions, ripe (score 0.8) at the points of ~planned and still green (0.3) everywhere else. The
server's plan for today must then be ~planned; the robot's uploader latches it on
/plan/picking_points, and only then is the mission started (task_planner/start). Afterwards:
  - the executive moved to exactly the planned points, in order, and the mission succeeded;
  - ground truth (/sim, tests only): every ripe reachable fruit of a planned point is in the box,
    every fruit of the other points still hangs untouched (ripe ones included), nothing damaged;
  - today's records reach the server and the plan changes: with the ripe fruit picked and the
    rest green, nothing is worth a visit any more, and the uploader latches an empty plan.
"""
import os
import shutil
import tempfile
import time
import unittest

import rospy
import rostest
import yaml
from harvest_msgs.msg import MissionEvent
from harvest_sim.msg import SimFruit, SimFruitArray
from std_msgs.msg import Int32MultiArray
from std_srvs.srv import Trigger

from database_pkg.store import Store
from harvest_test_utils.farm import FarmServer
from network_pkg.outbox import FarmClient, Outbox, Uploader

from mission_test import Watch

DAY = 86400.0
ROBOT = 'sim_robot'
RIPE_YESTERDAY, GREEN_YESTERDAY = 0.8, 0.3


class PlanWatch(Watch):
    """mission_test's watch, plus the latched plan and the executive's NEXT_POINT events."""

    def __init__(self):
        Watch.__init__(self)
        self.plan = None
        self.plans = []
        self.points = []
        rospy.Subscriber('/plan/picking_points', Int32MultiArray, self._plan_cb)
        rospy.Subscriber('/mission/events', MissionEvent, self._event_cb, queue_size=100)

    def _plan_cb(self, msg):
        with self.cond:
            self.plan = list(msg.data)
            self.plans.append(self.plan)
            self.cond.notify_all()

    def _event_cb(self, msg):
        if msg.state == 'NEXT_POINT':
            with self.cond:
                self.points.append(int(msg.detail.split()[-1]))   # 'picking point K'
                self.cond.notify_all()


def yesterdays_scan(fruits, track, planned, path, now):
    """Fill a store with one scan per picking point, a day ago, as this robot's earlier mission."""
    t0 = now - DAY
    stage = lambda s: 3 if s >= 0.7 else 2 if s >= 0.5 else 1 if s >= 0.25 else 0  # noqa: E731
    with Store(path, clock=lambda: t0) as store:
        mission = 'yesterday_scan'
        store.ensure_mission(mission, started=t0, site='')
        for k, track_position in enumerate(track):
            here = [f for f in fruits if f.picking_point == k]
            obs = []
            for i, f in enumerate(here):
                score = RIPE_YESTERDAY if (f.ripe and k in planned) else GREEN_YESTERDAY
                obs.append(dict(detection_id=i, position=(f.position.x, f.position.y, f.position.z),
                                frame_id='map', radius=f.radius, ripeness_stage=stage(score),
                                ripeness_score=score, pickable=score >= 0.7,
                                pick_order=i if score >= 0.7 else -1, stamp=t0 + 60.0 * k,
                                image_id='yesterday-%d' % k))
            if obs:
                store.add_observations(mission, k, track_position, obs, site='')
        store.end_mission(mission, t0 + 60.0 * len(track) + 60.0, 'scan only')


class MissionPlanTest(unittest.TestCase):
    def test_mission_follows_the_plan(self):
        w = WATCH
        planned = [int(p) for p in rospy.get_param('~planned')]
        with open(rospy.get_param('~token_file')) as f:
            token = f.read().strip()
        work = tempfile.mkdtemp(prefix='mission_plan_farm_')
        self.addCleanup(shutil.rmtree, work, True)
        server = FarmServer('sqlite:///' + os.path.join(work, 'farm.db'), work,
                            config_text=yaml.safe_dump({'robots': {ROBOT: token}}),
                            port=int(rospy.get_param('~farm_port')))
        self.addCleanup(server.stop)
        server.start(timeout=120.0)

        # yesterday: the robot scanned the row (uploaded through network_pkg's outbox and client)
        fruits = rospy.wait_for_message('/sim/fruits', SimFruitArray, timeout=120.0).fruits
        track = rospy.get_param('/track/picking_points')
        store_path = os.path.join(work, 'yesterday.db')
        yesterdays_scan(fruits, track, planned, store_path, time.time())
        client = FarmClient(server.url, token, timeout=10.0)
        outbox = Outbox(store_path)
        try:
            uploader = Uploader(outbox, client, batch_size=500)
            for _ in range(20):
                uploader.step()
                if uploader.status()['drained']:
                    break
            self.assertTrue(uploader.status()['drained'], uploader.status())
            self.assertEqual(uploader.status()['last_error'], '')
            plan = client.plan()
        finally:
            outbox.close()
            client.close()
        self.assertIsNotNone(plan, 'the server has no plan for %s' % ROBOT)
        self.assertEqual(plan['picking_points'], planned, plan)
        self.assertLess(len(planned), len(track), 'the fixture must leave points out')

        # today: the uploader latches the plan; then the mission starts
        self.assertTrue(w.wait(lambda: w.plan == planned, 120.0),
                        'uploader did not latch the plan %s (plans seen: %s)' % (planned, w.plans))
        rospy.wait_for_service('/task_planner/start', timeout=60.0)
        resp = rospy.ServiceProxy('/task_planner/start', Trigger)()
        self.assertTrue(resp.success, resp.message)
        self.assertTrue(w.wait(lambda: w.summary is not None, 600.0), 'no mission summary')
        s = w.summary
        self.assertEqual(s['outcome'], 'succeeded', s)
        # the points come as mission events, on a connection of their own
        w.wait(lambda: len(w.points) >= len(planned), 10.0)
        self.assertEqual(w.points, planned, 'picking points visited')
        self.assertEqual(s['points_visited'], len(planned), s)

        fruits = w.fruits_at_rest()
        self.assertIsNotNone(fruits, 'no /sim/fruits')
        for f in fruits:
            if f.picking_point in planned and f.ripe and f.reachable:
                self.assertEqual(f.state, SimFruit.COLLECTED, '%s at planned point %d: %s'
                                 % (f.id, f.picking_point, f.state_name))
            elif f.picking_point in planned:
                self.assertEqual(f.state, SimFruit.HANGING, '%s (not to pick): %s' % (f.id, f.state_name))
            else:
                self.assertEqual(f.state, SimFruit.HANGING, '%s at unplanned point %d: %s'
                                 % (f.id, f.picking_point, f.state_name))
        left_out = [f.id for f in fruits if f.ripe and f.reachable and f.picking_point not in planned]
        self.assertTrue(left_out, 'the scenario must have ripe fruit at unplanned points')
        self.assertEqual(s['picked'], sum(1 for f in fruits if f.state == SimFruit.COLLECTED), s)

        # today's records reach the server: the plan changes (nothing ripe is left to visit)
        self.assertTrue(w.wait(lambda: w.plan == [], 300.0),
                        'the plan did not change after the mission (plans seen: %s)' % w.plans)


if __name__ == '__main__':
    rospy.init_node('mission_plan_test')
    WATCH = PlanWatch()
    rostest.rosrun('harvest_bringup', 'mission_plan_test', MissionPlanTest)
