"""The farm page in headless Chromium (Debian `chromium`): strip, plans and harvest figures
rendered from the real server's /api/v1/overview; a screenshot is taken."""
import os
import re
import time

import pytest
import requests

import farm_harness
from farm_server.db import FarmDB
from farm_server.fusion_config import OUTCOME_NAMES

pytestmark = pytest.mark.skipif(farm_harness.chromium() is None,
                                reason='chromium not installed (apt-get install chromium)')


@pytest.fixture(scope='module')
def demo(tmp_path_factory):
    work = str(tmp_path_factory.mktemp('farm_page'))
    url = 'sqlite:///' + os.path.join(work, 'farm.db')
    db = FarmDB(url)
    tokens = dict((r, db.add_robot(r)) for r in ('robot_a', 'robot_b'))
    paths = dict((r, os.path.join(work, '%s.db' % r)) for r in tokens)
    day = farm_harness.demo_farm(paths, time.time() - 4 * farm_harness.DAY, days=4, points=10)
    server = farm_harness.FarmServer(url, work).start()
    for robot, path in paths.items():
        proc = farm_harness.start_uploader(path, server.url, tokens[robot], work, robot,
                                           batch_size=500, until_empty=True)
        assert proc.wait(60) == 0
    yield server, work, day
    server.stop()
    db.dispose()


def test_page_renders_strip_plans_and_harvest_figures(demo):
    server, work, day = demo
    overview = requests.get(server.url + '/api/v1/overview', params={'day': day.isoformat()},
                            timeout=10).json()
    result = farm_harness.chromium_run('%s/?day=%s' % (server.url, day.isoformat()), work,
                                       ['--virtual-time-budget=8000', '--dump-dom'])
    dom = result.stdout.decode()
    assert 'data-ready="1"' in dom, result.stderr.decode()[-2000:]
    points = overview['rows'][0]['points']
    cells = re.findall(r'<div class="cell( plan)?" data-point="(\d+)" data-ripe="(\d+)"', dom)
    assert [(int(k), int(n)) for _p, k, n in cells] == \
        [(p['picking_point'], p['expected_ripe']) for p in points]
    plan = [r for r in overview['robots'] if r['robot'] == 'robot_a'][0]['plan']
    assert sorted(int(k) for p, k, _n in cells if p) == sorted(plan['picking_points'])
    assert ', '.join(str(k) for k in plan['picking_points']) in dom
    # a column per outcome of the one enum (picked has its own two)
    headers = re.findall(r'<th[^>]*>([^<]*)</th>', dom)
    assert set(OUTCOME_NAMES.values()) <= set(headers), headers
    for robot in overview['robots']:
        assert '<td class="l">%s</td>' % robot['robot'] in dom
        assert '%.1f' % robot['mean_cycle_time'] in dom
        assert '<td>%d</td>' % robot['picked'] in dom


def test_page_screenshot(demo, tmp_path):
    server, work, day = demo
    out = str(tmp_path / 'farm_server.png')
    farm_harness.chromium_run('%s/?day=%s' % (server.url, day.isoformat()), work,
                              ['--window-size=1200,860', '--virtual-time-budget=8000',
                               '--screenshot=%s' % out])
    with open(out, 'rb') as f:
        data = f.read()
    assert data[:8] == b'\x89PNG\r\n\x1a\n' and len(data) > 20000


def test_page_reports_a_failing_api(tmp_path):
    """The page says so when the overview cannot be loaded (here: no server behind it)."""
    html = os.path.join(str(tmp_path), 'page.html')
    from farm_server.page import PAGE_HTML
    with open(html, 'w') as f:
        f.write(PAGE_HTML)
    result = farm_harness.chromium_run('file://' + html, str(tmp_path),
                                       ['--virtual-time-budget=5000', '--dump-dom'])
    dom = result.stdout.decode()
    assert 'data-ready="error"' in dom and 'cannot load the overview' in dom
