"""harvest_test_utils.xvfb: a virtual display that accepts clients when start_xvfb returns."""

import os
import shutil
import stat
import subprocess

import pytest

from harvest_test_utils.xvfb import XvfbError, start_xvfb, stop_process

needs_xvfb = pytest.mark.skipif(shutil.which('Xvfb') is None or shutil.which('xwininfo') is None,
                                reason='Xvfb and xwininfo (Debian xvfb, x11-utils) are not installed')


@needs_xvfb
def test_the_display_accepts_a_client_as_soon_as_it_is_returned():
    proc, display = start_xvfb('640x480x24')
    try:
        assert display.startswith(':') and display[1:].isdigit()
        out = subprocess.run(['xwininfo', '-root', '-display', display], stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, timeout=30)
        assert out.returncode == 0, out.stdout
        assert b'Width: 640' in out.stdout and b'Height: 480' in out.stdout
    finally:
        stop_process(proc)
    assert proc.poll() is not None


@needs_xvfb
def test_a_client_that_connects_as_the_last_one_leaves_is_not_refused():
    # without -noreset the server resets when its last client leaves and refuses one that
    # connects meanwhile (8 of 300 here): rviz aborted so beside the test's xwininfo polls
    proc, display = start_xvfb('320x240x24')
    refused = 0
    try:
        for _ in range(150):
            leaving = subprocess.Popen(['xwininfo', '-root', '-display', display], stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL)
            refused += subprocess.run(['xwininfo', '-root', '-display', display], stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL, timeout=30).returncode != 0
            refused += leaving.wait(30) != 0
    finally:
        stop_process(proc)
    assert refused == 0


@needs_xvfb
def test_two_displays_started_together_get_different_numbers():
    first = start_xvfb('320x240x24')
    try:
        second = start_xvfb('320x240x24')
        try:
            assert first[1] != second[1]
        finally:
            stop_process(second[0])
    finally:
        stop_process(first[0])


def fake_xvfb(tmp_path, monkeypatch, body):
    # a Python script: the pipe's descriptor can be above 9, beyond a POSIX shell's redirections
    script = tmp_path / 'Xvfb'
    script.write_text('#!/usr/bin/python3\nimport os, sys, time\n' + body + '\n')
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    monkeypatch.setenv('PATH', '%s%s%s' % (tmp_path, os.pathsep, os.environ.get('PATH', '')))


def test_an_xvfb_that_exits_at_once_is_a_clear_error(tmp_path, monkeypatch):
    fake_xvfb(tmp_path, monkeypatch, 'sys.exit(3)')
    with pytest.raises(XvfbError, match=r'exited before it reported a display \(exit code 3\)'):
        start_xvfb(timeout=20)


def test_an_xvfb_that_reports_nothing_is_stopped_after_the_timeout(tmp_path, monkeypatch):
    # the child keeps the pipe open and never writes: start_xvfb gives up and stops it
    fake_xvfb(tmp_path, monkeypatch, 'time.sleep(60)')
    with pytest.raises(XvfbError, match='no display within'):
        start_xvfb(timeout=0.5)


def test_an_xvfb_that_reports_no_number_is_a_clear_error(tmp_path, monkeypatch):
    # argv[2] is the descriptor number after -displayfd
    fake_xvfb(tmp_path, monkeypatch, 'os.write(int(sys.argv[2]), b"oops\\n")\ntime.sleep(60)')
    with pytest.raises(XvfbError, match="reported 'oops"):
        start_xvfb(timeout=20)


def test_without_xvfb_on_the_path_it_says_which_package_to_install(monkeypatch, tmp_path):
    monkeypatch.setenv('PATH', str(tmp_path))
    with pytest.raises(XvfbError, match='Debian package xvfb'):
        start_xvfb()
