"""TrackedActionClient keeps a result that arrives before send_goal() has stored the handle."""
import threading

import actionlib
import pytest
from actionlib_msgs.msg import GoalStatus

from harvest_test_utils.actions import TrackedActionClient


class _Handle(object):
    """A goal handle whose server has already answered (comm state DONE)."""

    def __init__(self, status=GoalStatus.SUCCEEDED):
        self.status = status

    def __eq__(self, other):
        return other is self

    def __ne__(self, other):
        return other is not self

    __hash__ = object.__hash__

    def get_comm_state(self):
        return actionlib.CommState.DONE

    def get_goal_status(self):
        return self.status

    def get_result(self):
        return 'result'


class _FastServer(object):
    """ActionClient stand-in: the transition callback runs before send_goal returns, in the
    sending thread (`same_thread`) or in another thread, as a subscriber callback would."""

    ns = 'fake'

    def __init__(self, same_thread):
        self.same_thread = same_thread
        self.callback_thread = None

    def send_goal(self, goal, transition_cb, feedback_cb):
        handle = _Handle()
        if self.same_thread:
            transition_cb(handle)
        else:
            self.callback_thread = threading.Thread(target=transition_cb, args=(handle,))
            self.callback_thread.start()
        return handle


def _client(cls, server):
    client = cls.__new__(cls)
    if cls is TrackedActionClient:
        client._init_tracking()
    client.action_client = server
    client.simple_state = actionlib.SimpleGoalState.DONE
    client.gh = None
    client.done_condition = threading.Condition()
    return client


@pytest.mark.parametrize('same_thread', [True, False])
def test_result_before_the_handle_is_stored_is_kept(same_thread):
    server = _FastServer(same_thread)
    client = _client(TrackedActionClient, server)
    done = []
    client.send_goal('goal', done_cb=lambda status, result: done.append((status, result)))
    if server.callback_thread is not None:
        server.callback_thread.join()
    assert client.simple_state == actionlib.SimpleGoalState.DONE
    assert done == [(GoalStatus.SUCCEEDED, 'result')]
    assert client.get_state() == GoalStatus.SUCCEEDED


def test_plain_simple_action_client_drops_it():
    # the race the class exists for: actionlib's own client loses the same result
    client = _client(actionlib.SimpleActionClient, _FastServer(same_thread=True))
    done = []
    client.send_goal('goal', done_cb=lambda status, result: done.append(status))
    assert done == []
    assert client.simple_state == actionlib.SimpleGoalState.PENDING
