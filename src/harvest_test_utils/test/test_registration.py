"""Every package with pytest files registers them with catkin (harvest_add_pytests), so one
`catkin_make run_tests` runs them and their JUnit files land in build/test_results/<package>."""

import glob
import os
import re
import xml.etree.ElementTree as ET

SRC = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))


def packages_with_pytests():
    found = []
    for xml in sorted(glob.glob(os.path.join(SRC, '*', 'package.xml'))):
        pkg_dir = os.path.dirname(xml)
        if glob.glob(os.path.join(pkg_dir, 'test', 'test_*.py')):
            found.append(pkg_dir)
    return found


def test_there_are_packages_with_pytests():
    names = [os.path.basename(p) for p in packages_with_pytests()]
    assert 'harvest_test_utils' in names and 'motion_pkg' in names


def test_every_package_with_pytests_registers_them():
    missing = []
    for pkg_dir in packages_with_pytests():
        with open(os.path.join(pkg_dir, 'CMakeLists.txt')) as f:
            cmake = f.read()
        testing = re.search(r'if\(CATKIN_ENABLE_TESTING\)(.*?)endif\(\)', cmake, re.S)
        if not testing or not re.search(r'harvest_add_pytests\(test\b', testing.group(1)):
            missing.append(os.path.basename(pkg_dir))
    assert missing == []


def test_every_registering_package_declares_the_test_depend():
    missing = []
    for pkg_dir in packages_with_pytests():
        name = os.path.basename(pkg_dir)
        if name == 'harvest_test_utils':
            continue
        root = ET.parse(os.path.join(pkg_dir, 'package.xml')).getroot()
        if 'harvest_test_utils' not in [d.text for d in root.findall('test_depend')]:
            missing.append(name)
    assert missing == []
