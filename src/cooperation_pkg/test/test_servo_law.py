"""The C++ ViSP control law (servo_law_check) against the numpy reference (ibvs_reference.py).

servo_law_check is built by catkin_make (tests only) into <devel>/lib/cooperation_pkg/; it is found
through CMAKE_PREFIX_PATH (source the devel setup.bash) or the SERVO_LAW_CHECK variable.
"""

import os
import subprocess

import numpy as np
import pytest

import ibvs_reference as ref

TOL = 1e-6


def _find_checker():
    env = os.environ.get('SERVO_LAW_CHECK')
    if env:
        return env
    for prefix in os.environ.get('CMAKE_PREFIX_PATH', '').split(os.pathsep):
        cand = os.path.join(prefix, 'lib', 'cooperation_pkg', 'servo_law_check')
        if prefix and os.access(cand, os.X_OK):
            return cand
    return None


CHECKER = _find_checker()
pytestmark = pytest.mark.skipif(CHECKER is None, reason='servo_law_check not built: catkin_make and source '
                                                       'devel/setup.bash (or set SERVO_LAW_CHECK)')


def run_checker(lines):
    out = subprocess.run([CHECKER], input='\n'.join(lines) + '\n', stdout=subprocess.PIPE,
                         universal_newlines=True, check=True, timeout=60).stdout
    return out.strip().split('\n')


def random_cases(n, seed):
    rng = np.random.RandomState(seed)
    cases = []
    for i in range(n):
        cur = (rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(0.05, 1.5))
        des = (rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(0.08, 0.6))
        gain = rng.uniform(0.05, 1.5)
        translation = (i % 2 == 0)
        adaptive = None
        if i % 3 == 0:
            adaptive = (gain * rng.uniform(0.1, 0.9), rng.uniform(0.5, 20.0))
        cases.append((cur, des, gain, translation, adaptive))
    return cases


def case_line(case):
    cur, des, gain, translation, adaptive = case
    vals = list(cur) + list(des) + [gain] + (list(adaptive) if adaptive else [])
    return ('t ' if translation else 'f ') + ' '.join(repr(float(v)) for v in vals)


def test_random_cases_match_reference():
    cases = random_cases(400, seed=7)
    out = run_checker([case_line(c) for c in cases])
    assert len(out) == len(cases)
    for case, line in zip(cases, out):
        cur, des, gain, translation, adaptive = case
        got = np.array([float(t) for t in line.split()])
        assert got.shape == (11,), line
        g_inf, slope = adaptive if adaptive else (None, None)
        v, lam = ref.control_law_and_gain(cur, des, gain, translation, g_inf, slope)
        np.testing.assert_allclose(got[:6], v, rtol=0, atol=TOL, err_msg=case_line(case))
        np.testing.assert_allclose(got[6:9], ref.feature_error(cur, des), rtol=0, atol=TOL)
        assert abs(got[9] - ref.error_at_target(cur, des)) < TOL
        assert abs(got[10] - lam) < TOL
        if translation:
            assert np.all(got[3:6] == 0.0)


def test_converging_trajectory_matches_reference():
    """Feed the reference trajectory of a simulated translating camera through both laws."""
    des = (0.0, -0.015 / 0.13, 0.13)
    p_star = ref.point_of(des)
    p = p_star + np.array([0.06, 0.04, 0.28])
    lines, feats = [], []
    for _ in range(12):
        cur = (p[0] / p[2], p[1] / p[2], p[2])
        feats.append(cur)
        lines.append(case_line((cur, des, 0.5, True, None)))
        p = p - ref.control_law(cur, des, 0.5)[:3]
    out = run_checker(lines)
    for cur, line in zip(feats, out):
        got = np.array([float(t) for t in line.split()])
        np.testing.assert_allclose(got[:6], ref.control_law(cur, des, 0.5), rtol=0, atol=TOL)
    assert ref.error_at_target(feats[-1], des) < 0.002


def test_invalid_features_are_rejected():
    out = run_checker(['t 0 0 0 0 0 0.13 0.5', 't 0 0 0.3 0 0 -1 0.5', 't 0 0 0.3 0 0 0.13 0', 'garbage'])
    assert all(line.startswith('error') for line in out), out
