"""The ur-bridge command line: every flag in --help, defaults as documented, and flags
that do not fit together refused by name before anything connects."""

import pytest

from hapticd.cli import build_parser
from hapticd.errors import LocalError
from hapticd.ur_bridge import options_from


def parse(*flags):
    return build_parser().parse_args(["ur-bridge", "--robot", "10.0.0.5", *flags])


def test_help_names_every_flag(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["ur-bridge", "--help"])
    text = capsys.readouterr().out
    for flag in ("--robot", "--server", "--seconds", "--virtual-mass", "--virtual-damping",
                 "--max-speed", "--max-accel", "--rate-hz", "--lookahead", "--gain",
                 "--force-source", "--modbus", "--modbus-map", "--enable-input", "--ur-modbus",
                 "--base-pose", "--workspace", "--force-deadband", "--force-cutoff-hz",
                 "--bias-time-constant", "--command-timeout-ms", "--stale-ms", "--watchdog-hz"):
        assert flag in text, flag


def test_defaults():
    o = options_from(parse())
    assert (o.rate_hz, o.lookahead_s, o.gain, o.max_speed) == (500.0, 0.03, 500.0, 0.25)
    assert (o.command_timeout_s, o.stale_s, o.force_source) == (0.010, 0.020, "rtde")
    assert o.ur_modbus == "10.0.0.5:502" and o.enable_input is None
    cb3 = options_from(parse("--rate-hz", "125"))
    assert cb3.rate_hz == 125.0


def test_a_base_pose_and_a_workspace_are_read():
    o = options_from(parse("--base-pose", "1,2,3,1,0,0,0", "--workspace", "0,0,0,1,1,1"))
    assert o.base_pose.to_scene((0, 0, 0)).tolist() == [1, 2, 3]
    assert o.workspace is not None and o.workspace.high == (1.0, 1.0, 1.0)


@pytest.mark.parametrize(
    ("flags", "named"),
    [(["--force-source", "modbus"], "--modbus"), (["--modbus", "h:1"], "--force-source modbus"),
     (["--ur-modbus", "h:502"], "--enable-input"), (["--enable-input", "16"], "--enable-input"),
     (["--workspace", "0,0,0,1,0,1"], "axis y"), (["--base-pose", "0,0,0,2,0,0,0"], "quaternion")],
)  # fmt: skip
def test_flags_that_do_not_fit_are_refused_by_name(flags, named):
    with pytest.raises(LocalError, match=named):
        options_from(parse(*flags))


@pytest.mark.parametrize(
    "flags",
    [["--rate-hz", "250"], ["--max-speed", "0"], ["--lookahead", "0.01"], ["--gain", "5000"],
     ["--seconds", "-1"], ["--base-pose", "1,2"]],
)  # fmt: skip
def test_out_of_range_values_are_refused_by_argparse(flags, capsys):
    with pytest.raises(SystemExit):
        parse(*flags)
    assert flags[0] in capsys.readouterr().err
