"""The stability maps' classifier (bench/stability_maps.py) on hand-built traces: one per
class, the precedence of pop-through, and a decaying oscillation that counts as stable."""

import importlib.util
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("stability_maps", REPO / "bench" / "stability_maps.py")
maps = importlib.util.module_from_spec(_spec)
sys.modules["stability_maps"] = maps  # dataclasses look their module up there
_spec.loader.exec_module(maps)

H = 0.0005  # plate half-thickness, m
MAX_FORCE = 8.0
T = np.arange(0, 1.5, 0.001)


def make_trace(dev_z, f_z, avatar_z=None):
    zeros = np.zeros_like(T)
    return {"t": T, "dev_x": zeros, "dev_y": zeros, "dev_z": dev_z, "f_x": zeros, "f_y": zeros,
            "f_z": f_z, "avatar_z": np.full_like(T, H) if avatar_z is None else avatar_z,
            "contact": np.ones_like(T)}


def classify(trace):
    return maps.classify(trace, {"contact_ticks": len(T)}, H, 0.0, MAX_FORCE)["class"]


def oscillation(amplitude_per_s, amplitude0=1e-3, hz=10.0):
    """dev_z = A(t) sin(2 pi hz t) with A(t) = amplitude0 * amplitude_per_s**t, and a force
    in phase with the velocity (1000 N·s/m), so that the force does positive work."""
    envelope = amplitude0 * amplitude_per_s ** T
    dev_z = -0.001 + envelope * np.sin(2 * np.pi * hz * T)
    return dev_z, 3.0 + 1000 * np.gradient(dev_z, T) * 0.01


def test_settled_contact_is_stable():
    dev_z = -0.001 - 0.002 * np.exp(-T / 0.05) * np.cos(60 * T)
    assert classify(make_trace(dev_z, 3000 * -dev_z)) == "stable"


def test_decaying_oscillation_is_stable():
    # still ~4 mm peak-to-peak at the end, but it halves every 0.3 s
    dev_z, f_z = oscillation(amplitude_per_s=0.5 ** (1 / 0.3), amplitude0=0.03)
    result = maps.classify(make_trace(dev_z, -f_z), {}, H, 0.0, MAX_FORCE)
    assert result["osc_dev_late_m"] > maps.OSC_DEV_M
    assert result["class"] == "stable"


def test_growing_oscillation_fed_by_the_force_is_energy_growing():
    dev_z, f_z = oscillation(amplitude_per_s=2.0)
    result = maps.classify(make_trace(dev_z, f_z), {}, H, 0.0, MAX_FORCE)
    assert result["energy_late_j"] > maps.ENERGY_GROWTH_J
    assert result["class"] == "energy_growing"


def test_force_chatter_without_net_work_is_a_limit_cycle():
    # the handle barely moves (20 um) while the force switches 0 <-> 2 N every 8 ticks,
    # each level held over a half-period that starts and ends at the same position, so
    # the force does no net work
    square = (np.arange(T.size) // 8) % 2
    dev_z = -0.006 + 1e-5 * np.sin(2 * np.pi * T / 0.016)
    result = maps.classify(make_trace(dev_z, 2.0 * square), {}, H, 0.0, MAX_FORCE)
    assert abs(result["energy_late_j"]) < maps.ENERGY_GROWTH_J
    assert result["class"] == "limit_cycle"


def test_saturating_force_is_a_limit_cycle_even_without_motion():
    f_z = np.where(np.arange(T.size) % 10 == 0, MAX_FORCE, 3.0)
    assert classify(make_trace(np.full_like(T, -0.001), f_z)) == "limit_cycle"


def test_pop_through_wins_over_everything():
    dev_z, f_z = oscillation(amplitude_per_s=2.0)
    avatar_z = np.where(T < 0.5, H, -H - 1e-6)
    assert classify(make_trace(dev_z, f_z, avatar_z)) == "pop_through"
    # just at the far side is not through
    assert classify(make_trace(np.full_like(T, -H), np.zeros_like(T), np.full_like(T, -H))) == "stable"
