"""Adds up the JUnit XML files of one `make test` run and prints one closing line, after the
name of every failed test and the first lines of why it failed (its JUnit message and text: a CI
log then says what went wrong, not only where).

Exit status 1 when any test failed or errored (a suite's errors outside any test case, such as
a failed setUpClass, count too), or when no test ran at all.

`--pytest-lines RESULTS PACKAGE...` prints instead one line per package from its pytest JUnit
file (RESULTS/PACKAGE/pytest-test.xml): "pytest PACKAGE: N passed[, F failed] in S s", or that
it has no result file.
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET

#: lines of a failure's message and text printed under its name
WHY_LINES = 15


def why(element, limit=WHY_LINES):
    """The first `limit` non-empty lines of a <failure>/<error>: its message, then its text."""
    lines = []
    for text in (element.get('message') or '', element.text or ''):
        lines += [line.rstrip() for line in text.splitlines() if line.strip()]
    if lines and len(lines) > 1 and lines[0].strip() in lines[1]:
        lines = lines[1:]       # the message repeated as the text's first line
    more = len(lines) - limit
    return lines[:limit] + (['... (%d more lines)' % more] if more > 0 else [])


def suites_of(path):
    """The <testsuite> elements of one JUnit XML file (its root, or the root's children)."""
    root = ET.parse(path).getroot()
    return [root] if root.tag == 'testsuite' else root.findall('testsuite')


def count(path, suites=None):
    """Return (tests, failures, errors, skipped, failed) of one JUnit XML file (or of its
    suites_of, if read already); failed: a (name, lines why) per failed or errored test case."""
    if suites is None:
        suites = suites_of(path)
    tests = failures = errors = skipped = 0
    failed = []
    for suite in suites:
        counted = failures + errors
        for case in suite.iter('testcase'):
            tests += 1
            bad = case.find('failure')
            if bad is not None:
                failures += 1
            else:
                bad = case.find('error')
                errors += bad is not None
            if bad is not None:
                failed.append(('%s.%s' % (case.get('classname'), case.get('name')), why(bad)))
            elif case.find('skipped') is not None:
                skipped += 1
        # errors outside any test case: rosunit writes a failed setUpClass (or a test process
        # that never ran a test) as <testsuite errors="1" tests="0"> with no <testcase>
        declared = _int(suite.get('errors')) + _int(suite.get('failures'))
        outside = declared - (failures + errors - counted)
        if outside > 0:
            tests += outside      # counted as one failed test each
            errors += outside
            lines = [line.rstrip() for tag in ('system-out', 'system-err')
                     for node in suite.iter(tag) for line in (node.text or '').splitlines()
                     if line.strip() and line.strip() not in ('<![CDATA[', ']]>')]
            failed.append(('%s (%d error(s) outside any test case, e.g. in setUpClass: the '
                           "test node's log has the traceback)" % (suite.get('name'), outside),
                           lines[:WHY_LINES]))
    return tests, failures, errors, skipped, failed


def _int(text):
    try:
        return int(text or 0)
    except ValueError:
        return 0


def pytest_line(results_dir, package):
    """The "pytest PACKAGE: ..." line of one package's pytest JUnit file."""
    path = os.path.join(results_dir, package, 'pytest-test.xml')
    if not os.path.exists(path):
        return 'pytest %s: no result file (%s)' % (package, path)
    try:
        suites = suites_of(path)
    except ET.ParseError as exc:
        return 'pytest %s: unreadable result file %s: %s' % (package, path, exc)
    tests, failures, errors, skipped, _ = count(path, suites)
    seconds = sum(float(suite.get('time') or 0.0) for suite in suites)
    parts = ['%d passed' % (tests - failures - errors - skipped)]
    parts += ['%d %s' % (n, what) for n, what in ((failures, 'failed'), (errors, 'errors'),
                                                  (skipped, 'skipped')) if n]
    return 'pytest %s: %s in %.2fs' % (package, ', '.join(parts), seconds)


def main(results_dir):
    files = sorted(glob.glob(os.path.join(results_dir, '**', '*.xml'), recursive=True))
    total = failed_n = skipped_n = 0
    failed_names = []
    for path in files:
        try:
            t, f, e, s, names = count(path)
        except ET.ParseError as exc:
            print('unreadable result file %s: %s' % (path, exc))
            failed_n += 1
            continue
        total += t
        failed_n += f + e
        skipped_n += s
        failed_names += [('%s: %s' % (os.path.relpath(path, results_dir), n), lines)
                         for n, lines in names]
    for name, lines in failed_names:
        print('FAILED', name)
        for line in lines:
            print('    ' + line)
    passed = total - failed_n - skipped_n
    print('%d passed, %d failed, %d skipped' % (passed, failed_n, skipped_n))
    return 1 if failed_n or total == 0 else 0


if __name__ == '__main__':
    if len(sys.argv) > 2 and sys.argv[1] == '--pytest-lines':
        for name in sys.argv[3:]:
            print(pytest_line(sys.argv[2], name))
        sys.exit(0)
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else 'test_results'))
