"""Benchmark of the simulator (bench_sim), measured in this process: the render cost of the
stereo pair and the hand camera (render_cost) and the per-frame stage costs of the perception
pipeline (stage_costs, --profile). Re-exported by harvest_sim.bench."""

import os
import time

import numpy as np


def _paths():
    here = os.path.dirname(os.path.abspath(__file__))
    pkg = os.path.normpath(os.path.join(here, '..', '..'))
    try:
        import rospkg
        rp = rospkg.RosPack()
        return rp.get_path('harvest_sim'), os.path.join(rp.get_path('harvest_description'),
                                                        'config', 'robot.yaml')
    except Exception:      # noqa: BLE001 - no ROS environment: source tree
        return pkg, os.path.join(pkg, '..', 'harvest_description', 'config', 'robot.yaml')


def _median_ms(fn, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) * 1000.0)
    return float(np.median(times))


def _scene(scenario_name):
    from harvest_sim import render, scenario as scn
    from motion_pkg.kinematics import RobotGeometry
    pkg, robot = _paths()
    geom = RobotGeometry.from_yaml(robot)
    s = scn.load_scenario(scn.resolve_scenario(scenario_name, os.path.join(pkg, 'scenarios')))
    return s, geom, render


def render_cost(scenario_name, frames, save_image=None):
    """Mean / median ms per stereo eye frame and per hand frame (full re-render each time), and
    the median ms of a frame of a still scene (cached layer)."""
    from harvest_sim import camera_model
    s, geom, render = _scene(scenario_name)
    t0 = time.perf_counter()
    r = render.Renderer(s)
    init_ms = (time.perf_counter() - t0) * 1000
    fr = render.fruits_from_scenario(s)
    stereo, hand = camera_model.stereo_camera(), camera_model.hand_camera()
    y0 = s.track.picking_points[0]
    ik = geom.inverse('left', (0.5, 0.0, 1.0))
    res = {'init_ms': init_ms, 'stereo_ms': [], 'hand_ms': []}
    still = geom.frame_transforms({'cart_joint': y0})
    r.render(stereo, still['stereo_left_optical'], fr, ('left', 0))   # warm caches
    for i in range(frames):
        poses = geom.frame_transforms({'cart_joint': y0 + 0.002 * (i + 1),
                                       'left_lift_joint': ik.joints[0] + 0.001 * i,
                                       'left_boom_joint': ik.joints[1],
                                       'left_forearm_joint': ik.joints[2]})
        for eye in ('stereo_left_optical', 'stereo_right_optical'):
            t = time.perf_counter()
            r.render(stereo, poses[eye], fr, (eye, i))
            res['stereo_ms'].append((time.perf_counter() - t) * 1000)
        t = time.perf_counter()
        r.render(hand, poses['hand_camera_optical'], fr, ('hand', i))
        res['hand_ms'].append((time.perf_counter() - t) * 1000)
    counter = [0]

    def cached():
        counter[0] += 1
        r.render(stereo, still['stereo_left_optical'], fr, ('left', counter[0]))
    res['cached_ms'] = _median_ms(cached, max(5, frames))
    if save_image:
        import cv2
        cv2.imwrite(save_image, r.render(stereo, still['stereo_left_optical'], fr, ('left', 0)))
    return res


def stage_costs(scenario_name, repeat=7):
    """Median ms of the per-frame stages of the perception pipeline, in this process."""
    import io
    import cv2
    import rospkg
    import yaml
    from sensor_msgs.msg import Image, PointCloud2, PointField
    from harvest_sim import camera_model
    out = {}
    s, geom, render = _scene(scenario_name)
    r = render.Renderer(s)
    fr = render.fruits_from_scenario(s)
    cam = camera_model.stereo_camera()
    poses = geom.frame_transforms({'cart_joint': s.track.picking_points[0]})
    left = r.render(cam, poses['stereo_left_optical'], fr, ('left', 0))
    right = r.render(cam, poses['stereo_right_optical'], fr, ('right', 0))
    msg = Image(height=cam.height, width=cam.width, encoding='bgr8', step=cam.width * 3,
                data=left.tobytes())
    buf = io.BytesIO()
    msg.serialize(buf)
    data = buf.getvalue()

    def ser():
        b = io.BytesIO()
        msg.serialize(b)
    out['Image 1024x768 bgr8: serialise'] = _median_ms(ser, repeat)
    out['Image 1024x768 bgr8: deserialise'] = _median_ms(lambda: Image().deserialize(data),
                                                         repeat)
    fields = [PointField(name=n, offset=o, datatype=PointField.FLOAT32, count=1)
              for n, o in (('x', 0), ('y', 4), ('z', 8), ('rgb', 16))]
    cloud = PointCloud2(height=cam.height, width=cam.width, fields=fields, point_step=32,
                        row_step=32 * cam.width, is_dense=False,
                        data=bytes(32 * cam.width * cam.height))
    buf = io.BytesIO()
    cloud.serialize(buf)
    cdata = buf.getvalue()
    out['PointCloud2 1024x768 XYZRGB (25 MB): serialise'] = _median_ms(
        lambda: cloud.serialize(io.BytesIO()), repeat)
    out['PointCloud2 1024x768 XYZRGB: deserialise'] = _median_ms(
        lambda: PointCloud2().deserialize(cdata), repeat)
    # stereo_image_proc's work: rectify both eyes (colour + mono), block matching, point cloud
    mapx, mapy = np.meshgrid(np.arange(cam.width, dtype=np.float32),
                             np.arange(cam.height, dtype=np.float32))

    def rectify():
        for img in (left, right):
            cv2.remap(img, mapx, mapy, cv2.INTER_LINEAR)
            cv2.remap(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY), mapx, mapy, cv2.INTER_LINEAR)
    out['stereo: rectify both eyes (colour + mono remaps)'] = _median_ms(rectify, repeat)
    try:
        from vision_pkg import localisation
        vp = rospkg.RosPack().get_path('vision_pkg')
        with open(os.path.join(vp, 'config', 'stereo_image_proc.yaml')) as f:
            params = yaml.safe_load(f)
        bm = localisation.stereo_bm_from_params(params)
        gl, gr = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY), cv2.cvtColor(right, cv2.COLOR_BGR2GRAY)
        out['stereo: StereoBM (robot parameters)'] = _median_ms(lambda: bm.compute(gl, gr),
                                                                 repeat)
        disp = bm.compute(gl, gr).astype(np.float32) / 16.0
        disp[disp < params.get('min_disparity', 0)] = np.nan
        baseline = geom.stereo_baseline
        out['stereo: disparity -> organised cloud'] = _median_ms(
            lambda: localisation.cloud_from_disparity(disp, cam.fx, cam.fy, cam.cx, cam.cy,
                                                      baseline), repeat)
        from vision_pkg.detection import TomatoDetector
        vcfg = os.path.join(vp, 'config', 'image_processing.yaml')
        with open(vcfg) as f:
            det_params = yaml.safe_load(f).get('stereo_detection', {})
        det = TomatoDetector(**det_params)
        out['detection: stereo right image (1024x768)'] = _median_ms(lambda: det.detect(right),
                                                                     repeat)
        xyz = localisation.cloud_from_disparity(disp, cam.fx, cam.fy, cam.cx, cam.cy, baseline)
        packed = np.zeros((cam.height, cam.width, 8), np.float32)
        packed[:, :, :3] = xyz
        raw = packed.tobytes()
        dets = det.detect(right)
        P = cam.P(-cam.fx * baseline).flatten().tolist()

        def decode_locate():
            c = localisation.cloud_array(raw, cam.height, cam.width, 32, 32 * cam.width,
                                         (0, 4, 8))
            for d in dets:
                localisation.locate(c, d, P, image=right)
        out['image_processing: points2 decode + locate (%d fruit)' % len(dets)] = \
            _median_ms(decode_locate, repeat)
    except ImportError as exc:
        out['vision stages'] = 'skipped (%s)' % exc
    try:
        import rospy
        import tf2_py
        from geometry_msgs.msg import TransformStamped
        buf = tf2_py.BufferCore(rospy.Duration(60.0))
        for k in range(200):
            for parent, child in (('map', 'base_link'), ('base_link', 'stereo_left_optical')):
                t = TransformStamped()
                t.header.stamp = rospy.Time(100.0 + 0.05 * k)
                t.header.frame_id, t.child_frame_id = parent, child
                t.transform.rotation.w = 1.0
                buf.set_transform(t, 'bench')
        out['tf2 lookup (2 frames, interpolated), per call'] = _median_ms(
            lambda: buf.lookup_transform_core('map', 'stereo_left_optical',
                                              rospy.Time(105.025)),
            repeat * 50)
    except ImportError as exc:
        out['tf'] = 'skipped (%s)' % exc
    return out
