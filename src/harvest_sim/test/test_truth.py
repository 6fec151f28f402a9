"""harvest_sim.truth: the ground truth the tools and bench_sim read at a mission's end."""
from harvest_sim.msg import SimFruit
from harvest_sim.srv import GetSimSummaryResponse
from harvest_sim.truth import fruit_in_hand, ground_truth_counts


def test_ground_truth_waits_for_the_fruit_on_the_suction_sleeve():
    # the summary can arrive before the world lets the last fruit go into the box: the fruit
    # still held (or cut and not let go) are what the ground truth must wait for
    fruits = [SimFruit(id='a', state=SimFruit.COLLECTED), SimFruit(id='b', state=SimFruit.HARVESTED),
              SimFruit(id='c', state=SimFruit.HELD), SimFruit(id='d', state=SimFruit.HANGING)]
    assert fruit_in_hand(fruits) == ['b', 'c']
    assert fruit_in_hand(fruits[:1] + fruits[3:]) == []


def test_a_fruit_cut_and_still_on_the_sleeve_counts_as_harvested():
    summary = GetSimSummaryResponse(ripe_reachable=6, collected=5, harvested=1, dropped=1,
                                    damaged=1)
    assert ground_truth_counts(summary) == (6, 6, 2)
