"""Every whole-mission rostest reports under a JUnit name of its own (MissionTest.test_<test-name>),
so the summary of `make test` says which scenario failed."""

import glob
import os
import sys
import unittest
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, 'rostest'))   # this package's rostest node (mission_test.py)

import mission_test  # noqa: E402


def case_names(case):
    return unittest.TestLoader().getTestCaseNames(case)


def test_the_case_is_named_after_the_test_name():
    case = mission_test.scenario_case('/mission_estop')
    assert case_names(case) == ['test_mission_estop']
    assert case.__name__ == 'MissionTest'
    assert case.test_mission_estop is mission_test.MissionTest.run_mission


def test_the_plain_case_runs_nothing_by_itself():
    assert case_names(mission_test.MissionTest) == []


def test_every_mission_test_file_gets_its_own_name():
    names = []
    for path in sorted(glob.glob(os.path.join(HERE, 'rostest', '*.test'))):
        for test in ET.parse(path).getroot().iter('test'):
            if test.get('type') == 'mission_test.py':
                names += case_names(mission_test.scenario_case(test.get('test-name')))
    assert len(names) >= 7
    assert len(set(names)) == len(names)
    assert 'test_mission_three_targets' in names
