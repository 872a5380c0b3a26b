import math

import numpy as np
import pytest

from hitrobot_server.robot.model import Pose2D
from hitrobot_server.robot.sim.lidar import Lidar, LidarConfig, RayCaster

NOISE = 0.01


@pytest.fixture
def lidar(world):
    return Lidar(RayCaster(world.spec, world.solid), LidarConfig(), np.random.default_rng(0))


def _beam(lidar, angle):
    return int(np.argmin(np.abs(np.angle(np.exp(1j * (lidar.angles - angle))))))


def test_ranges_match_the_corridor_geometry(lidar):
    # Robot in the corridor (walls at y = 7.0 and 9.0, west wall face at x = 0.2), heading east.
    ranges = lidar.measure(Pose2D(5.0, 8.0, 0.0))
    expected = {
        math.pi / 2: 1.0,
        -math.pi / 2: 1.0,
        -math.pi: 4.8,
        math.pi / 4: math.sqrt(2.0),
        3 * math.pi / 4: math.sqrt(2.0),
    }
    for angle, distance in expected.items():
        assert ranges[_beam(lidar, angle)] == pytest.approx(distance, abs=5 * NOISE)
    # Straight down the corridor the east end is 18 m away: beyond the 12 m range.
    assert math.isinf(ranges[_beam(lidar, 0.0)])


def test_beams_rotate_with_the_robot(lidar):
    ranges = lidar.measure(Pose2D(5.0, 8.0, math.pi / 2))
    assert ranges[_beam(lidar, 0.0)] == pytest.approx(1.0, abs=5 * NOISE)
    assert ranges[_beam(lidar, math.pi / 2)] == pytest.approx(4.8, abs=5 * NOISE)


def test_noise_is_seeded(world):
    def scan(seed):
        rng = np.random.default_rng(seed)
        return Lidar(RayCaster(world.spec, world.solid), LidarConfig(), rng).measure(
            Pose2D(10.0, 3.5, 0.3)
        )

    np.testing.assert_array_equal(scan(4), scan(4))
    finite = np.isfinite(scan(4))
    assert not np.array_equal(scan(4)[finite], scan(5)[finite])


def test_noise_free_caster_is_millimetre_accurate(world):
    caster = RayCaster(world.spec, world.solid)
    angles = np.linspace(-math.pi, math.pi, 7, endpoint=False)
    ranges = caster.cast(5.0, 8.0, np.array([math.pi / 2, -math.pi / 2]), 12.0)
    np.testing.assert_allclose(ranges, [1.0, 1.0], atol=2e-3)
    # Several origins at once (as the sonars use it).
    many = caster.cast(np.full(7, 5.0), np.full(7, 8.0), angles, 12.0)
    assert many.shape == (7,)
