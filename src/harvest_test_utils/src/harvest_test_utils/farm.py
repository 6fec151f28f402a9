"""The farm server (package farm_server, ``python -m farm_server serve``) as a child process on
a free loopback port, for network_pkg's tests and harvest_bringup's mission_plan rostest.

farm_server must be importable (the workspace sourced: devel/setup.bash); the caller's package
declares it. No ROS.
"""

import os
import subprocess
import sys

import requests

from harvest_test_utils.net import free_port, wait_for


def subprocess_env():
    """The environment of a child Python process: this one's (PYTHONPATH of the sourced
    workspace included), unbuffered output."""
    env = dict(os.environ)
    env['PYTHONUNBUFFERED'] = '1'
    return env


class FarmServer(object):
    """``farm_server serve`` as a child process on a loopback port."""

    def __init__(self, db_url, workdir, config_text=None, port=None):
        self.db_url = db_url
        self.port = port or free_port()
        self.url = 'http://127.0.0.1:%d' % self.port
        self.log_path = os.path.join(workdir, 'farm_server_%d.log' % self.port)
        self.config = None
        if config_text:
            self.config = os.path.join(workdir, 'farm_%d.yaml' % self.port)
            with open(self.config, 'w') as f:
                f.write(config_text)
        self.proc = None

    def start(self, timeout=90.0):
        cmd = [sys.executable, '-m', 'farm_server', '--db', self.db_url, 'serve',
               '--port', str(self.port), '--log-level', 'warning']
        if self.config:
            cmd += ['--config', self.config]
        log = open(self.log_path, 'ab')
        self.proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                                     env=subprocess_env())
        log.close()

        def up():
            if self.proc.poll() is not None:
                raise AssertionError('farm server exited with %s:\n%s'
                                     % (self.proc.returncode, self.log()))
            try:
                return requests.get(self.url + '/api/v1/health', timeout=1.0).ok
            except requests.RequestException:
                return False
        wait_for(up, timeout, 'the farm server on port %d' % self.port, interval=0.1)
        return self

    def log(self):
        try:
            with open(self.log_path) as f:
                return f.read()[-3000:]
        except OSError:
            return ''

    def kill(self):
        """SIGKILL: no clean shutdown (a crash or power cut of the server)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)
        self.proc = None

    def stop(self):
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
        self.proc = None
