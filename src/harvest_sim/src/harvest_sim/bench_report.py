"""Benchmark of the simulator (bench_sim), its report: the line of a whole-stack run (run_line)
and the per-node CPU / frames table of the --profile run (print_profile, PROFILE_ROWS,
FRAME_TOPICS). Re-exported by harvest_sim.bench."""

import math

#: rows of the per-node profile: (label, node names, topic whose frames the node handles)
PROFILE_ROWS = (
    ('renderer, stereo pair', ('sim_stereo_camera',), 'stereo'),
    ('renderer, hand camera', ('sim_hand_camera',), 'hand'),
    ('image relays (stereo)', ('dual_eye_image_capture',), 'stereo'),
    ('image relays (hand)', ('single_eye_image_capture',), 'hand'),
    ('stereo_image_proc (rectify, BM, points2)', ('stereo_image_proc',), 'points2'),
    ('image_processing (detection, localisation, subs)', ('image_processing',), 'points2'),
    ('tf: robot_state_publisher', ('robot_state_publisher',), None),
    ('sim_clock', ('sim_clock',), None),
    ('Modbus: motion_server + sim_controller', ('motion_server', 'sim_controller'), None),
    ('sim_world', ('sim_world',), None),
    ('executive, self-test, kinematics, database, servo',
     ('task_planner', 'self_test_server', 'kinematics_server', 'database_node', 'visual_servo'),
     None),
)


def _frames(frames, topic_suffixes, sub=None):
    """Most frames delivered on a topic ending with one of topic_suffixes (to sub if given)."""
    best = 0
    for key, n in frames.items():
        topic, node = key.split('|', 1)
        if any(topic.endswith(s) for s in topic_suffixes) and (sub is None or sub in node):
            best = max(best, n)
    return best


FRAME_TOPICS = {'stereo': ('left/image_raw',), 'hand': ('hand_eye/image_raw',
                                                        'hand_camera/image_raw'),
                'points2': ('points2',)}


def print_profile(res, scale):
    cpu, frames = res.get('cpu', {}), res.get('frames', {})
    span, sim = res.get('cpu_span', 0.0), res.get('sim', 0.0)
    print('profile at time scale %g (%s): %.0f s wall, %.0f s sim; CPU %% of one core over the '
          'mission; frames per simulated second; CPU ms per frame' % (
              scale, res.get('summary', {}).get('mission_id', ''), span, sim))
    print('| stage | nodes | CPU % | frames / sim s | CPU ms / frame |')
    print('|---|---|---:|---:|---:|')
    counted = set()
    for label, nodes, kind in PROFILE_ROWS:
        share = sum(cpu.get(n, 0.0) for n in nodes)
        counted.update(nodes)
        if kind:
            n = _frames(frames, FRAME_TOPICS[kind])
            rate = '%.2f' % (n / sim) if sim > 0 else '-'
            ms = '%.0f' % (share / 100.0 * span * 1000.0 / n) if n else '-'
        else:
            rate, ms = '-', '-'
        print('| %s | %s | %.0f | %s | %s |' % (label, ', '.join(nodes), share, rate, ms))
    rest = sorted(((k, v) for k, v in cpu.items() if k not in counted and v >= 0.5),
                  key=lambda kv: -kv[1])
    print('| other | %s | %.0f | - | - |' % (', '.join('%s %.0f' % kv for kv in rest),
                                             sum(v for _, v in rest)))
    print('| total | | %.0f | | |' % sum(cpu.values()))


def run_line(scale, res):
    if 'error' in res:
        return 'time scale %g: FAILED: %s' % (scale, res['error'])
    s, truth = res['summary'], res.get('truth', {})
    cycle = s.get('mean_cycle_time')
    cycle = 'n/a' if cycle is None or (isinstance(cycle, float) and math.isnan(cycle)) \
        else '%.1f' % cycle
    split = res.get('split', {})
    return ('time scale %g: speed reached %.2f (%.0f s sim in %.1f s wall: %.1f s moving, %.1f s '
            'at rest, %.1f s held by cameras; launch to summary %.1f s); mission %s, picked %s '
            'of %s ripe reachable (truth: harvested %s, dropped %s, damaged %s), mean cycle %s '
            's/fruit (sim)' % (
                scale, res['speed'], res['sim'], res['wall'], split.get('fast', 0.0),
                split.get('rest', 0.0), split.get('held', 0.0), res['wall_total'],
                s['outcome'], s['picked'], truth.get('ripe_reachable', '?'),
                truth.get('harvested', '?'), truth.get('dropped', '?'),
                truth.get('damaged', '?'), cycle))
