"""control_pkg.node_watch: a respawned node (a new URI) is a restart, nothing else is."""
from control_pkg.node_watch import RestartTracker, restart_detail


def test_first_sighting_and_an_unchanged_uri_are_not_restarts():
    tracker = RestartTracker(['/image_processing', '/database_node'])
    assert tracker.update({'/image_processing': 'http://h:4001/', '/database_node': None}) == []
    assert tracker.update({'/image_processing': 'http://h:4001/',
                           '/database_node': 'http://h:4002/'}) == []


def test_a_new_uri_is_a_restart_once():
    tracker = RestartTracker(['/image_processing'])
    tracker.update({'/image_processing': 'http://h:4001/'})
    assert tracker.update({'/image_processing': 'http://h:4107/'}) == [
        ('/image_processing', 'http://h:4001/', 'http://h:4107/')]
    assert tracker.update({'/image_processing': 'http://h:4107/'}) == []


def test_a_node_gone_for_a_while_is_judged_against_its_last_uri():
    tracker = RestartTracker(['/visual_servo'])
    tracker.update({'/visual_servo': 'http://h:4001/'})
    assert tracker.update({'/visual_servo': None}) == []          # dead, not respawned yet
    assert tracker.update({}) == []
    assert tracker.update({'/visual_servo': 'http://h:4301/'}) == [
        ('/visual_servo', 'http://h:4001/', 'http://h:4301/')]


def test_only_watched_nodes_are_reported():
    tracker = RestartTracker(['/uploader'])
    tracker.update({'/uploader': 'a', '/other': 'x'})
    assert tracker.update({'/uploader': 'a', '/other': 'y'}) == []


def test_restart_detail_names_the_node_and_both_processes():
    text = restart_detail('/image_processing', 'http://h:4001/', 'http://h:4107/')
    assert '/image_processing' in text and 'http://h:4107/' in text and 'http://h:4001/' in text
