"""The round monitor's count of a window's captured frames."""
from hri_sync.tools.round_summary import frames_brought


def test_two_people_in_one_frame_are_one_frame():
    # Two skeletons (participant and bystander) per frame: 98 frames
    # brought in 196 messages are not yet the result's 100 frames.
    samples = [(10.0 + 0.05 * k, None, None) for k in range(98)] * 2
    assert frames_brought(samples) == 98
    assert frames_brought([]) == 0
