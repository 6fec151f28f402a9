"""The uploader's logic without a server: outbox queue, back-off, Uploader.step (no ROS)."""
import random
import sqlite3

import pytest

import farm_harness
from database_pkg.store import Store
from network_pkg.outbox import Backoff, Batch, Outbox, UploadError, Uploader


@pytest.fixture
def db_path(tmp_path):
    return str(tmp_path / 'robot.db')


def fill(path, scans=3, fruit=4):
    with Store(path, synchronous='NORMAL') as s:
        s.add_event(dict(mission_id='m1', stamp=10.0, kind='state', state='DO_START', detail=''))
        for k in range(scans):
            s.add_observations('m1', k, 0.5 * k, [farm_harness.tomato(i, (0.5, 0.05 * i, 0.9),
                                                                      0.8, 11.0 + k)
                                                 for i in range(fruit)], site='row1')
            s.add_pick_record(farm_harness.pick('m1', k, 0, (0.5, 0.0, 0.9), 12.0 + k))


class FakeClient(object):
    """Records payloads; fails while ``failures`` holds exceptions."""

    def __init__(self, failures=()):
        self.failures = list(failures)
        self.payloads = []

    def upload(self, payload):
        if self.failures:
            raise self.failures.pop(0)
        self.payloads.append(payload)
        return {'duplicates': 0}


def test_batches_come_missions_first_then_in_insertion_order(db_path):
    fill(db_path)
    outbox = Outbox(db_path)
    assert outbox.pending_counts() == {'missions': 1, 'events': 1, 'pick_records': 3,
                                       'observations': 12}
    batch = outbox.next_batch(6)
    assert [len(batch.rows[t]) for t in ('missions', 'events', 'pick_records',
                                         'observations')] == [1, 1, 3, 1]
    first = batch.rows['observations'][0]
    assert first['pickable'] is True and first['picking_point'] == 0 and len(first['id']) == 32
    assert 'uploaded' not in first
    assert batch.rows['pick_records'][0]['state_names'] == ['DO_KINEMATICS', 'DO_MOVE_ROBOT',
                                                            'DO_CUT']
    assert outbox.mark_uploaded(batch) == 6
    nxt = outbox.next_batch(100)
    assert len(nxt) == 11 and not nxt.rows['missions']
    ids = [o['id'] for o in nxt.rows['observations']]
    assert first['id'] not in ids
    outbox.close()


def test_a_mission_changed_after_reading_stays_queued(db_path):
    fill(db_path, scans=1)
    outbox = Outbox(db_path)
    batch = outbox.next_batch(100)
    sent_revision = batch.rows['missions'][0]['revision']
    with Store(db_path) as s:                   # the executive ends the mission meanwhile
        s.end_mission('m1', 99.0, 'done')
    outbox.mark_uploaded(batch)
    again = outbox.next_batch(100)
    assert len(again) == 1
    assert again.rows['missions'][0]['revision'] == sent_revision + 1
    assert again.rows['missions'][0]['summary'] == 'done'
    outbox.mark_uploaded(again)
    assert sum(outbox.pending_counts().values()) == 0
    outbox.close()


def test_queue_survives_a_restart(db_path):
    fill(db_path)
    outbox = Outbox(db_path)
    outbox.mark_uploaded(outbox.next_batch(5))
    outbox.close()
    outbox = Outbox(db_path)                   # "the robot restarted"
    assert sum(outbox.pending_counts().values()) == 17 - 5
    outbox.close()


def test_backoff_grows_exponentially_with_jitter_and_resets():
    rng = random.Random(1)
    b = Backoff(initial=1.0, maximum=8.0, rng=rng)
    delays = [b.failure() for _ in range(6)]
    caps = [1, 2, 4, 8, 8, 8]
    for d, cap in zip(delays, caps):
        assert cap / 2.0 <= d <= cap
    assert len(set(round(d, 6) for d in delays)) == 6          # jittered
    b.success()
    assert b.cap() == 0.0 and 0.5 <= b.failure() <= 1.0
    with pytest.raises(ValueError):
        Backoff(initial=0.0)


def test_uploader_backs_off_while_the_server_is_down_then_drains(db_path):
    fill(db_path)
    down = UploadError('server unreachable: ConnectionError')
    client = FakeClient([down, down, down])
    now = [1000.0]
    up = Uploader(Outbox(db_path), client, batch_size=10,
                  backoff=Backoff(1.0, 4.0, rng=random.Random(0)), idle_period=2.0,
                  clock=lambda: now[0])
    delays = [up.step() for _ in range(3)]
    assert 0.5 <= delays[0] <= 1.0 and 1.0 <= delays[1] <= 2.0 and 2.0 <= delays[2] <= 4.0
    status = up.status()
    assert status['consecutive_failures'] == 3 and 'unreachable' in status['last_error']
    assert status['last_success_time'] is None and status['sent'] == 0
    assert up.step() == 0.0                    # back: first batch, then at once the next
    assert up.step() == 0.0
    assert up.step() == 2.0                    # drained: idle
    status = up.status()
    assert status['sent'] == 17 and status['batches'] == 2 and status['drained']
    assert status['consecutive_failures'] == 0 and status['last_success_time'] == 1000.0
    sent_ids = [r['id'] for p in client.payloads for t in p for r in p[t]]
    assert len(sent_ids) == len(set(sent_ids)) == 17


def test_uploader_halves_the_batch_on_413(db_path):
    fill(db_path)
    client = FakeClient([UploadError('too big', status=413), UploadError('too big', status=413)])
    up = Uploader(Outbox(db_path), client, batch_size=16)
    while up.step() == 0.0:
        pass
    assert up.batch_size == 4
    assert max(sum(len(v) for v in p.values()) for p in client.payloads) == 4
    assert up.status()['sent'] == 17


def test_rejected_token_is_reported_and_retried_later(db_path):
    fill(db_path, scans=1)
    client = FakeClient([UploadError('upload refused: HTTP 401', status=401)])
    up = Uploader(Outbox(db_path), client, backoff=Backoff(5.0, 60.0))
    assert up.step() >= 2.5
    assert up.status()['last_error_status'] == 401
    assert farm_harness.pending(db_path) == 7   # nothing marked


def test_crash_between_send_and_mark_resends_the_same_ids(db_path):
    fill(db_path, scans=1)
    client = FakeClient()
    outbox = Outbox(db_path)
    batch = outbox.next_batch(100)
    client.upload(batch.payload())              # sent, then "the process dies"
    outbox.close()
    up = Uploader(Outbox(db_path), client)
    up.step()
    first, second = client.payloads
    assert first == second                      # same ids and content: the server skips them


def test_store_errors_are_backed_off_not_raised(db_path, monkeypatch):
    fill(db_path, scans=1)
    outbox = Outbox(db_path)

    def broken(_n):
        raise sqlite3.OperationalError('database is locked')
    monkeypatch.setattr(outbox, 'next_batch', broken)
    up = Uploader(outbox, FakeClient(), backoff=Backoff(1.0, 2.0))
    assert up.step() > 0 and 'database is locked' in up.status()['last_error']


def test_batch_payload_leaves_out_empty_tables():
    b = Batch()
    b.rows['events'] = [{'id': 'x'}]
    assert b.payload() == {'events': [{'id': 'x'}]} and len(b) == 1
