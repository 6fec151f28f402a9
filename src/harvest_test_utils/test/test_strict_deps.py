"""harvest_test_utils.strict_deps: with HARVEST_STRICT_DEPS=1 a skip fails, unless optional."""

import pytest

pytest_plugins = ['pytester']

PLUGIN = ('-p', 'harvest_test_utils.strict_deps')


def run(pytester, monkeypatch, source, strict=True):
    if strict:
        monkeypatch.setenv('HARVEST_STRICT_DEPS', '1')
    else:
        monkeypatch.delenv('HARVEST_STRICT_DEPS', raising=False)
    pytester.makepyfile(test_case=source)
    return pytester.runpytest(*PLUGIN)


def test_module_level_importorskip_fails(pytester, monkeypatch):
    result = run(pytester, monkeypatch, '''
        import pytest
        pytest.importorskip('no_such_module_harvest')

        def test_a():
            pass
        ''')
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(['*HARVEST_STRICT_DEPS=1: skipped*no_such_module_harvest*'])


def test_skipif_mark_fails(pytester, monkeypatch):
    result = run(pytester, monkeypatch, '''
        import pytest

        @pytest.mark.skipif(True, reason='mbpoll not installed')
        def test_a():
            pass

        def test_b():
            pass
        ''')
    result.assert_outcomes(passed=1, errors=1)
    result.stdout.fnmatch_lines(['*mbpoll not installed*'])


def test_skip_in_the_test_body_fails(pytester, monkeypatch):
    result = run(pytester, monkeypatch, '''
        import pytest

        def test_a():
            pytest.skip('PostgreSQL binaries not installed')
        ''')
    result.assert_outcomes(failed=1)


def test_optional_skip_stays_a_skip(pytester, monkeypatch):
    result = run(pytester, monkeypatch, '''
        from harvest_test_utils.strict_deps import skip_optional

        def test_a():
            skip_optional('smach_ros is installed here')
        ''')
    result.assert_outcomes(skipped=1)
    assert result.ret == 0


def test_xfail_is_not_a_skip(pytester, monkeypatch):
    result = run(pytester, monkeypatch, '''
        import pytest

        @pytest.mark.xfail(reason='known', strict=True)
        def test_a():
            assert False
        ''')
    result.assert_outcomes(xfailed=1)


def test_without_the_variable_skips_stay_skips(pytester, monkeypatch):
    result = run(pytester, monkeypatch, '''
        import pytest

        @pytest.mark.skipif(True, reason='mbpoll not installed')
        def test_a():
            pass

        def test_b():
            pytest.skip('chromium not installed')
        ''', strict=False)
    result.assert_outcomes(skipped=2)
    assert result.ret == 0


def test_strict_failure_lands_in_the_junit_file(pytester, monkeypatch):
    monkeypatch.setenv('HARVEST_STRICT_DEPS', '1')
    pytester.makepyfile(test_case='''
        import pytest

        @pytest.mark.skipif(True, reason='check_urdf missing')
        def test_a():
            pass
        ''')
    xml = pytester.path / 'out.xml'
    pytester.runpytest(*PLUGIN, '--junitxml=%s' % xml, '-o', 'junit_family=xunit1')
    text = xml.read_text()
    assert '<skipped' not in text
    assert '<error' in text and 'check_urdf missing' in text
