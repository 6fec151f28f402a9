"""pytest plugin: with HARVEST_STRICT_DEPS=1 a skipped test fails.

`make test` (tools/run_tests.sh) sets HARVEST_STRICT_DEPS=1: everything a test skips for
(a Debian package, a PyPI package, a built target, a message package) is installed or built by
tools/setup.sh, so a skip there means the set-up is broken and must not pass as "skipped".
Only a skip whose reason starts with OPTIONAL (use skip_optional()) stays a skip: something
tools/setup.sh does not install (e.g. smach_ros, not packaged in Debian 12).

Loaded with ``-p harvest_test_utils.strict_deps`` (harvest_add_pytests() does so). Without
HARVEST_STRICT_DEPS=1 it changes nothing.
"""

import os

import pytest

OPTIONAL = '[optional] '
ENV = 'HARVEST_STRICT_DEPS'


def skip_optional(reason):
    """Skip the running test for something tools/setup.sh does not install."""
    pytest.skip(OPTIONAL + reason)


def strict():
    return os.environ.get(ENV, '') == '1'


def skip_reason(report):
    """The reason text of a skipped report ('' when it has none)."""
    longrepr = report.longrepr
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        reason = str(longrepr[2])
    else:
        reason = str(longrepr or '')
    if reason.startswith('Skipped: '):
        reason = reason[len('Skipped: '):]
    return reason


def fail_required_skip(report):
    """Turn a skipped (not xfail, not optional) report into a failure; True if it did."""
    if not strict() or not report.skipped or hasattr(report, 'wasxfail'):
        return False
    reason = skip_reason(report)
    if reason.startswith(OPTIONAL):
        return False
    report.outcome = 'failed'
    report.longrepr = ('%s=1: skipped, but tools/setup.sh installs or builds what this test '
                       'needs, so the set-up is broken: %s' % (ENV, reason))
    return True


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    fail_required_skip(outcome.get_result())      # module-level importorskip / pytest.skip


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    fail_required_skip(outcome.get_result())      # skipif marks (setup), pytest.skip (call)
