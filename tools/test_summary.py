"""Adds up the JUnit XML files of one `make test` run and prints one closing line.

Exit status 1 when any test failed or errored, or when no test ran at all.
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def count(path):
    """Return (tests, failures, errors, skipped, failed_names) of one JUnit XML file."""
    root = ET.parse(path).getroot()
    suites = [root] if root.tag == 'testsuite' else root.findall('testsuite')
    tests = failures = errors = skipped = 0
    failed = []
    for suite in suites:
        for case in suite.iter('testcase'):
            tests += 1
            if case.find('failure') is not None:
                failures += 1
                failed.append('%s.%s' % (case.get('classname'), case.get('name')))
            elif case.find('error') is not None:
                errors += 1
                failed.append('%s.%s' % (case.get('classname'), case.get('name')))
            elif case.find('skipped') is not None:
                skipped += 1
    return tests, failures, errors, skipped, failed


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
        failed_names += ['%s: %s' % (os.path.relpath(path, results_dir), n) for n in names]
    for name in failed_names:
        print('FAILED', name)
    passed = total - failed_n - skipped_n
    print('%d passed, %d failed, %d skipped' % (passed, failed_n, skipped_n))
    return 1 if failed_n or total == 0 else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else 'test_results'))
