"""The simulator's ground truth at the end of a mission, for the tools and benchmarks that run
one (tools/run_demo.py and through it `make demo`, the load check and bench_mission;
harvest_sim.bench_runs, `bench_sim`). The robot stack never reads it."""
import threading


def ground_truth_counts(summary):
    """(ripe reachable, harvested, damaged) from harvest_sim's GetSimSummary response: a fruit
    cut and still on the suction sleeve (harvested) counts with those in the box."""
    return (int(summary.ripe_reachable), int(summary.harvested + summary.collected),
            int(summary.dropped + summary.damaged))


def fruit_in_hand(fruits):
    """Ids of the simulator's fruit still on the suction sleeve (held, or cut and not let go)."""
    from harvest_sim.msg import SimFruit
    return [f.id for f in fruits if f.state in (SimFruit.HELD, SimFruit.HARVESTED)]


def wait_fruits_at_rest(launch, timeout=30.0):
    """Wait (ROS time, at most `timeout` s) until no fruit is on the suction sleeve; returns the
    last /sim/fruits list (None if none came). The mission's end and the valve's last closing
    reach the world on different topics, so the summary can come before the world has let the
    last fruit go into the box: read at once, the ground truth counted it missing (load-check
    empty_point, 'executive record 4, box 3', one run in several; bench_sim 'collected 5' of
    6 picked). launch: the roslaunch process (Popen); its end ends the wait."""
    import rospy
    from harvest_sim.msg import SimFruitArray
    cond = threading.Condition()
    latest = {}

    def on_fruits(msg):
        with cond:
            latest['fruits'] = list(msg.fruits)
            cond.notify_all()
    sub = rospy.Subscriber('/sim/fruits', SimFruitArray, on_fruits)
    try:
        deadline = rospy.get_time() + timeout
        with cond:
            while not rospy.is_shutdown() and launch.poll() is None and \
                    rospy.get_time() < deadline and \
                    ('fruits' not in latest or fruit_in_hand(latest['fruits'])):
                cond.wait(0.5)
            return latest.get('fruits')
    finally:
        sub.unregister()
