"""The simulated hand and device against analytic answers: an undamped spring-mass
(cosine, period, constant energy), a damped one, a constant held force, the energy
account, saturation, and the admittance variant."""

import math

import numpy as np
import pytest

from hapticd.errors import LocalError
from hapticd.sim_device import (
    DeviceSpec,
    HandPath,
    HandSpec,
    SimAdmittanceDevice,
    SimImpedanceDevice,
    calc_substeps,
)

RATE_HZ = 1000.0
DT = 1 / RATE_HZ


def spring_mass(stiffness=300.0, damping=0.0, device_damping=0.0, start=(0.01, 0, 0)):
    """Hand 0.3 kg + device 0.05 kg pulled towards the origin, released at rest."""
    hand = HandSpec(mass=0.3, stiffness=stiffness, damping=damping, path=[[0, 0, 0, 0]])
    device = DeviceSpec(mass=0.05, damping=device_damping, max_force=8.0, start=start)
    return SimImpedanceDevice(hand, device, RATE_HZ)


def run(device, ticks, force=None):
    positions = []
    for k in range(ticks):
        device.sample(k * DT)
        if force is not None:
            device.accept(force)
        device.advance(k * DT)
        positions.append(device.position.copy())
    return np.array(positions)


def test_undamped_spring_mass_follows_the_cosine():
    device = spring_mass()
    omega = math.sqrt(300 / 0.35)
    x = run(device, 2000)[:, 0]
    t = (np.arange(2000) + 1) * DT
    assert np.max(np.abs(x - 0.01 * np.cos(omega * t))) < 1e-10


def test_undamped_spring_mass_keeps_its_energy():
    device = spring_mass()
    run(device, 3000)
    energy = 0.5 * 0.35 * float(device.velocity @ device.velocity) + 0.5 * 300 * float(
        device.position @ device.position
    )
    assert energy == pytest.approx(0.5 * 300 * 0.01**2, rel=1e-9)


def test_the_period_is_two_pi_over_omega():
    device = spring_mass()
    x = run(device, 3000)[:, 0]
    # downward zero crossings, interpolated between ticks
    crossings = [
        (k + x[k] / (x[k] - x[k + 1])) * DT + DT for k in range(len(x) - 1) if x[k] > 0 >= x[k + 1]
    ]
    period = np.diff(crossings)
    assert np.allclose(period, 2 * math.pi / math.sqrt(300 / 0.35), rtol=1e-6)


def test_damped_spring_mass_decays_as_the_analytic_solution():
    hand_damping, device_damping = 2.0, 0.5
    device = spring_mass(damping=hand_damping, device_damping=device_damping)
    m, k, b = 0.35, 300.0, hand_damping + device_damping
    omega = math.sqrt(k / m)
    zeta = b / (2 * math.sqrt(k * m))
    omega_d = omega * math.sqrt(1 - zeta**2)
    t = (np.arange(1500) + 1) * DT
    expected = (
        0.01
        * np.exp(-zeta * omega * t)
        * (np.cos(omega_d * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(omega_d * t))
    )
    assert np.max(np.abs(run(device, 1500)[:, 0] - expected)) < 1e-10


def test_a_held_force_settles_at_force_over_stiffness_and_counts_its_work():
    device = spring_mass(damping=5.0, start=(0, 0, 0))
    positions = run(device, 5000, force=(0, 0, 3.0))
    assert positions[-1] == pytest.approx([0, 0, 3.0 / 300], abs=1e-9)
    # the work of a constant force is F times the displacement
    assert device.energy_j == pytest.approx(3.0 * positions[-1][2], rel=1e-12)


def test_the_sample_reports_the_force_held_over_the_last_tick():
    device = spring_mass()
    assert np.array_equal(device.sample(0).force, [0, 0, 0])
    device.accept((1.0, 2.0, 2.0))
    device.advance(0)
    assert np.array_equal(device.sample(DT).force, [1.0, 2.0, 2.0])


def test_a_force_over_max_force_is_saturated_along_its_direction():
    device = spring_mass()
    device.accept((0, 30.0, 40.0))
    assert np.allclose(device.held_force, [0, 8.0 * 0.6, 8.0 * 0.8])


def test_a_non_finite_force_renders_zero():
    device = spring_mass()
    device.accept((1.0, 0, 0))
    device.accept((math.nan, 0, 0))
    assert np.array_equal(device.held_force, [0, 0, 0])


def test_substeps_are_at_least_twenty_and_grow_with_stiffness():
    assert calc_substeps(0.35, 300, 5, DT) == 20
    # omega = 1000 rad/s: omega dt / 0.05 = 20; 4000 rad/s: 80
    assert calc_substeps(1.0, 16e6, 0, DT) == 80
    with pytest.raises(LocalError, match="too stiff"):
        calc_substeps(1e-6, 1e9, 0, DT)


def test_the_path_interpolates_and_holds_its_ends():
    path = HandPath([[0.0, 0, 0, 0], [1.0, 1, 0, 0], [3.0, 1, 2, 0]])
    assert path.position_at(-1) == (0, 0, 0)
    assert path.position_at(0.25) == (0.25, 0, 0)
    assert path.position_at(2.0) == (1, 1, 0)
    assert path.position_at(10) == (1, 2, 0)
    # at a point, the next segment's slope; none outside the path
    assert path.velocity_at(1.0) == (0, 1, 0)
    assert path.velocity_at(0.5) == (1, 0, 0)
    assert path.velocity_at(-1) == (0, 0, 0)
    assert path.velocity_at(3.0) == (0, 0, 0)


def test_a_path_whose_times_do_not_increase_is_refused_by_name():
    with pytest.raises(
        LocalError, match=r"path\[2\]\[0\] is 1.0; it must be > 1.0, the time of path\[1\]"
    ):
        HandPath([[0, 0, 0, 0], [1, 0, 0, 0], [1, 1, 0, 0]])
    with pytest.raises(LocalError, match="path is empty"):
        HandPath(np.zeros((0, 4)))


def test_admittance_senses_the_hand_and_goes_where_commanded():
    hand = HandSpec(mass=0.3, stiffness=300, damping=5, path=[[0, 0, 0, 0.0], [1, 0, 0, -0.1]])
    device = SimAdmittanceDevice(
        hand, DeviceSpec(mass=0.05, damping=0, max_force=20, start=(0, 0, 0))
    )
    sample = device.sample(0.5)
    # the hand wants z = -0.05 moving at -0.1 m/s; the handle is at rest at the origin
    assert np.allclose(sample.force, [0, 0, 300 * -0.05 + 5 * -0.1])
    device.accept((0, 0, -0.002))
    device.advance(0.5)
    assert np.allclose(device.position, [0, 0, -0.002])
    assert np.allclose(device.velocity, [0, 0, -2.0])
    # the hand did the work: the rendered (reaction) force's work is negative
    assert device.energy_j == pytest.approx(-(300 * -0.05 + 5 * -0.1) * -0.002)
    device.accept((math.nan, 0, 0))
    device.advance(0.501)
    assert np.allclose(device.position, [0, 0, -0.002])


def test_a_quantizing_sensor_reports_a_finite_difference_velocity():
    hand = HandSpec(mass=0.3, stiffness=0, damping=0, path=[[0, 0, 0, 0]])
    spec = DeviceSpec(
        mass=0.05, damping=0, max_force=8, start=(0.0012, 0, 0), position_resolution=0.001
    )
    device = SimAdmittanceDevice(hand, spec)
    assert np.allclose(device.sample(0).position, [0.001, 0, 0])
    device.accept((0.0031, 0, 0))
    device.advance(0)
    sample = device.sample(DT)
    assert np.allclose(sample.position, [0.003, 0, 0])
    assert np.allclose(sample.velocity, [2.0, 0, 0])
