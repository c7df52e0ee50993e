"""The command lines' bad arguments: one line naming the argument, exit code 2, nothing run.

The driver, the calibration and the demos share :class:`subfric_dolfinx.commandline.
ArgumentParser` (issue 26): argparse's usage paragraph is not printed, the error is. Run
in-process (numpy only); the demos' processes are checked in ``test_cli.py``.
"""

import pytest

from subfric_dolfinx.calibrate.cli import main as calibrate_main
from subfric_dolfinx.commandline import EXIT_USAGE, ArgumentError, ArgumentParser
from subfric_dolfinx.driver.cli import main as driver_main
from subfric_dolfinx.scenes import cli as demo_cli

pytestmark = pytest.mark.numpy_only


def one_error_line(err: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert "usage:" not in err, err
    return lines[0]


@pytest.mark.parametrize("main", [driver_main, calibrate_main], ids=["driver", "calibrate"])
@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["x.json", "--out", "o.json", "--steps-per-mm", "abc"], ["--steps-per-mm", "'abc'"]),
        (["x.json", "--out", "o.json", "--bogus"], ["unrecognized", "--bogus"]),
        (["x.json", "--out"], ["--out", "expected one argument"]),
        ([], ["required", "the following arguments"]),
    ],
    ids=["malformed-value", "unknown-option", "no-value", "missing"],
)
def test_a_bad_argument_is_one_line_and_exit_code_2(
    main, argv, words, tmp_path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == EXIT_USAGE
    out = capsys.readouterr()
    line = one_error_line(out.err)
    assert line.startswith("error: "), line
    assert all(w in line for w in words), line
    assert out.out == "" and not (tmp_path / "o.json").exists()


def test_a_demo_s_bad_argument_is_one_line_and_exit_code_2(capsys):
    ap = demo_cli.demo_parser("test", prog="demo")
    ap.add_argument("--n", type=int, default=4)
    with pytest.raises(SystemExit) as e:
        demo_cli.parse_args(ap, ["--n", "abc"])
    assert e.value.code == EXIT_USAGE
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith("demo: error: argument --n") and "'abc'" in line, line


def test_help_still_prints_and_exits_0(capsys):
    ap = ArgumentParser(prog="tool", description="A tool.")
    ap.add_argument("--n", type=int, help="how many")
    with pytest.raises(SystemExit) as e:
        ap.parse_args(["--help"])
    assert e.value.code == 0
    assert "usage: tool" in capsys.readouterr().out
    with pytest.raises(ArgumentError, match="argument --n: invalid int value: 'x'"):
        ap.parse_args(["--n", "x"])
