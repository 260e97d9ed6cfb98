"""The collision checker's distance formula against a brute-force minimum."""

import numpy as np

from reach_addon.core.collision import point_segment_distance, segment_distance_float


def brute_distance(p1, q1, p2, q2, n=401):
    """Least distance over an n × n grid of points on the two segments: never below the
    true minimum, and above it by at most half a grid step of each segment's length."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    a = p1 + s * (q1 - p1)
    b = p2 + s * (q2 - p2)
    return float(np.min(np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1)))


def test_segment_distance_is_the_least_distance_between_the_segments():
    rng = np.random.default_rng(7)
    cases = [tuple(rng.uniform(-1, 1, (4, 3))) for _ in range(150)]
    p = rng.uniform(-1, 1, 3)
    d = rng.uniform(-1, 1, 3)
    cases += [
        (p, p + d, p + [0.0, 0.3, 0.0], p + [0.0, 0.3, 0.0] + 2 * d),    # parallel
        (p, p + d, p + 0.5 * d, p + 3 * d),                              # collinear, overlapping
        (p, p, p + d, p + 2 * d),                                        # a point and a segment
        (p, p, p + d, p + d),                                            # two points
        (p, p + d, p + d, p + 2 * d + [0.1, 0.0, 0.0]),                  # touching ends
    ]
    for p1, q1, p2, q2 in cases:
        p1, q1, p2, q2 = (np.asarray(v, float) for v in (p1, q1, p2, q2))
        exact = segment_distance_float(p1.tolist(), q1.tolist(), p2.tolist(), q2.tolist())
        brute = brute_distance(p1, q1, p2, q2)
        slack = 0.5 / 400 * (np.linalg.norm(q1 - p1) + np.linalg.norm(q2 - p2)) + 1e-12
        assert brute - slack <= exact <= brute + 1e-12, (p1, q1, p2, q2, exact, brute)
        if np.linalg.norm(q2 - p2) == 0.0:
            assert abs(exact - point_segment_distance(p2.tolist(), p1.tolist(), q1.tolist())) < 1e-12
