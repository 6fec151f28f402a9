"""tools/test_summary.py: the closing line of `make test`, and why each failed test failed."""

import pytest

from harvest_test_utils.tools import load_tool

JUNIT = '''<?xml version="1.0" encoding="utf-8"?>
<testsuite name="mission" tests="3" failures="1" errors="1">
  <testcase classname="__main__.MissionTest" name="test_mission_executive_killed">
    <failure message="AssertionError: 1 != 0 : [('restart', 'task_planner restarted')]">Traceback (most recent call last):
  File "mission_test.py", line 150, in check_records_after_restart
%s
AssertionError: 1 != 0 : [('restart', 'task_planner restarted')]</failure>
  </testcase>
  <testcase classname="__main__.MissionTest" name="test_other">
    <error message="no mission summary"></error>
  </testcase>
  <testcase classname="__main__.MissionTest" name="test_fine"/>
</testsuite>
'''


@pytest.fixture(scope='module')
def summary():
    return load_tool('test_summary')


def test_failed_tests_are_named_with_the_first_lines_of_why(summary, tmp_path, capsys):
    filler = '\n'.join('    frame %d' % i for i in range(30))
    (tmp_path / 'harvest_bringup').mkdir()
    (tmp_path / 'harvest_bringup' / 'rosunit-mission.xml').write_text(JUNIT % filler)
    assert summary.main(str(tmp_path)) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0] == ('FAILED harvest_bringup/rosunit-mission.xml: '
                      '__main__.MissionTest.test_mission_executive_killed')
    assert out[1] == "    AssertionError: 1 != 0 : [('restart', 'task_planner restarted')]"
    assert out[2] == '    Traceback (most recent call last):'
    cut = out.index('    ... (%d more lines)' % (34 - summary.WHY_LINES))
    assert cut == 1 + summary.WHY_LINES
    assert out[cut + 1] == 'FAILED harvest_bringup/rosunit-mission.xml: __main__.MissionTest.test_other'
    assert out[cut + 2] == '    no mission summary'
    assert out[-1] == '1 passed, 2 failed, 0 skipped'


def test_all_passed_is_exit_status_0_and_no_result_at_all_is_1(summary, tmp_path, capsys):
    (tmp_path / 'ok.xml').write_text('<testsuite><testcase classname="a" name="b"/></testsuite>')
    assert summary.main(str(tmp_path)) == 0
    assert capsys.readouterr().out.splitlines() == ['1 passed, 0 failed, 0 skipped']
    assert summary.main(str(tmp_path / 'none')) == 1


def test_an_error_outside_any_test_case_fails(summary, tmp_path, capsys):
    # rosunit's file when setUpClass failed: no <testcase>, only the suite's error count
    (tmp_path / 'ok.xml').write_text('<testsuite><testcase classname="a" name="b"/></testsuite>')
    (tmp_path / 'rosunit-motion_server_test.xml').write_text(
        '<testsuite errors="1" failures="0" name="unittest.suite.TestSuite" tests="0">'
        '<system-out><![CDATA[\n\n]]></system-out></testsuite>')
    assert summary.main(str(tmp_path)) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith('FAILED rosunit-motion_server_test.xml: unittest.suite.TestSuite '
                             '(1 error(s) outside any test case')
    assert out[-1] == '1 passed, 1 failed, 0 skipped'


def test_pytest_lines_are_read_from_each_packages_junit_file(summary, tmp_path):
    """`make test`'s per-package lines: counts and time from the package's own file, so a log
    whose lines come in another order (the Docker image's) cannot give them the wrong name."""
    (tmp_path / 'vision_pkg').mkdir()
    (tmp_path / 'vision_pkg' / 'pytest-test.xml').write_text(
        '<testsuites><testsuite name="vision_pkg" tests="3" time="10.36">'
        '<testcase classname="a" name="b"/><testcase classname="a" name="c">'
        '<failure message="x"/></testcase><testcase classname="a" name="d">'
        '<skipped/></testcase></testsuite></testsuites>')
    (tmp_path / 'motion_pkg').mkdir()
    (tmp_path / 'motion_pkg' / 'pytest-test.xml').write_text(
        '<testsuites><testsuite name="motion_pkg" tests="1" time="2.5">'
        '<testcase classname="a" name="b"/></testsuite></testsuites>')
    assert summary.pytest_line(str(tmp_path), 'vision_pkg') == \
        'pytest vision_pkg: 1 passed, 1 failed, 1 skipped in 10.36s'
    assert summary.pytest_line(str(tmp_path), 'motion_pkg') == 'pytest motion_pkg: 1 passed in 2.50s'
    assert summary.pytest_line(str(tmp_path), 'nothing').startswith(
        'pytest nothing: no result file')
    (tmp_path / 'broken').mkdir()
    (tmp_path / 'broken' / 'pytest-test.xml').write_text('<testsuites><testsuite')
    assert 'unreadable result file' in summary.pytest_line(str(tmp_path), 'broken')
