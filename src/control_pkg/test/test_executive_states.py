"""control_pkg.executive_states: what the executive's own states share and how a resume starts."""
from control_pkg.smach_compat import smach


def test_clear_preempts_services_every_pending_request_in_a_tree():
    # a preempt that reached a state as it finished stays pending on it; after an emergency
    # stop the mission must start again with none (else its next run ends 'preempted' at once)
    from control_pkg.executive_states import clear_preempts

    class Quick(smach.State):
        def __init__(self):
            smach.State.__init__(self, outcomes=['done'])

        def execute(self, ud):
            return 'done'

    inner = smach.StateMachine(outcomes=['done'])
    with inner:
        smach.StateMachine.add('A', Quick())
    cc = smach.Concurrence(outcomes=['done'], default_outcome='done')
    with cc:
        smach.Concurrence.add('INNER', inner)
        smach.Concurrence.add('B', Quick())
    leaf_a, leaf_b = inner.get_children()['A'], cc.get_children()['B']
    leaf_a.request_preempt()
    leaf_b.request_preempt()
    inner.request_preempt()
    clear_preempts(cc)
    assert not any(s.preempt_requested() for s in (cc, inner, leaf_a, leaf_b))
    assert inner.execute(smach.UserData()) == 'done'
