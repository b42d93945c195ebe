"""Bad input: one-line error, non-zero exit, no traceback, no partial file."""

import json
import sys

import pytest

from cocomopl.cli import main

from conftest import assert_one_line_error, run_cli, run_cli_process


@pytest.mark.parametrize("args, words", [
    (["generate", "--lengths-mm", "abc"], ["'abc'", "not a number"]),  # refused by the parser
    (["dataset", "info", "nope.h5"], ["nope.h5", "not found"]),  # refused by the command
])
def test_a_mistake_in_a_process_of_its_own_is_one_line_and_exit_2(tmp_path, args, words):
    """The other tests call the command's entry point in the test's process; here the whole
    program runs as a user runs it, so nothing the interpreter prints at exit escapes them."""
    result = run_cli_process(*args, cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert_one_line_error(result, *words)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize(
    "lengths, words",
    [
        ("abc", ["'abc'", "not a number"]),
        ("150,-250", ["'-250'", "positive"]),
        ("150,nan", ["'nan'", "positive"]),
        ("0", ["'0'", "positive"]),
        ("150,150", ["distinct"]),
        ("", ["no step lengths"]),
        ("5000", ["5000", "beyond reach"]),
        ("0.15,0.25", ["0.15 mm", "millimetres", "150 mm"]),
    ],
)
def test_bad_lengths(tmp_path, lengths, words):
    out = tmp_path / "d.h5"
    result = run_cli("dataset", "generate", "--lengths-mm", lengths, "--out", str(out))
    assert_one_line_error(result, *words)
    assert list(tmp_path.iterdir()) == []


def test_extra_transition_between_untrained_lengths(tmp_path):
    result = run_cli("dataset", "generate", "--lengths-mm", "150,200", "--extra-transitions-mm", "150-250",
                     "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, "150-250", "250 mm is not one of the training lengths")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_length_beyond_the_robots_reach(tmp_path):
    result = run_cli("dataset", "generate", "--lengths-mm", "150,700", "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, "700 mm", "beyond talos's reach")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_stance_the_robot_cannot_take(tmp_path):
    """Romeo's description sets no reach: inverse kinematics finds its legs too short."""
    result = run_cli("dataset", "generate", "--robot", "romeo", "--lengths-mm", "780", "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, "cannot place its feet")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("command, path", [
    (["walk", "--no-video"], ["--to", "1,0,0"]),
    (["generate"], ["--to", "1,0,0"]),
    (["generate"], ["--footsteps", "plan.csv"]),
])
def test_first_swing_is_refused_where_the_footsteps_are_given_or_planned(tmp_path, command, path):
    (tmp_path / "plan.csv").write_text("x_m,y_m,yaw_deg,side\n0,0.085,0,left\n0,-0.085,0,right\n0.2,0.085,0,left\n")
    out = tmp_path / "out"
    path = [str(tmp_path / p) if p.endswith(".csv") else p for p in path]
    result = run_cli(*command, *path, "--first-swing", "right", "--out", str(out))
    assert_one_line_error(result, "--first-swing is used only with --lengths-mm")
    assert not out.exists()


@pytest.mark.slow
def test_unknown_robot(tmp_path):
    result = run_cli("dataset", "generate", "--robot", "wall-e", "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, "unknown robot", "wall-e")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_missing_urdf(tmp_path):
    desc = tmp_path / "bot.json"
    desc.write_text('{"name": "bot", "urdf": "nowhere.urdf", "pelvis": "base"}')
    result = run_cli("dataset", "generate", "--robot", str(desc), "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, "URDF not found")
    assert not (tmp_path / "d.h5").exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    "option",
    [["--workers", "0"], ["--dt", "-1"], ["--max-iterations", "x"], ["--load-transfer-weight", "-0.001"], ["--min-knee-flexion-rad", "-0.1"],
     ["--upper-velocity-weight", "-1"]],
)
def test_bad_numeric_options(tmp_path, option):
    result = run_cli("dataset", "generate", *option, "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, option[0])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_knee_bend_beyond_the_knee_limits(tmp_path):
    result = run_cli("dataset", "generate", "--min-knee-flexion-rad", "3", "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, "beyond talos's knee limits")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_unwritable_output():
    result = run_cli("dataset", "generate", "--lengths-mm", "200", "--out", "/proc/cocomopl/d.h5")
    assert_one_line_error(result, "cannot create the folder of --out /proc/cocomopl/d.h5")


@pytest.mark.slow
def test_unreachable_scheduler(tmp_path):
    result = run_cli("dataset", "generate", "--lengths-mm", "200", "--scheduler", "tcp://127.0.0.1:9", "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, "Dask scheduler")
    assert list(tmp_path.iterdir()) == []  # not even the working folder of the parts


@pytest.mark.slow
@pytest.mark.parametrize("command", ["info", "check"])
def test_unreadable_files(tmp_path, small_dataset, command):
    missing = tmp_path / "missing.h5"
    assert_one_line_error(run_cli("dataset", command, str(missing)), "not found")
    foreign = tmp_path / "foreign.h5"
    foreign.write_text("this is not HDF5")
    assert_one_line_error(run_cli("dataset", command, str(foreign)), "not a readable HDF5")
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(small_dataset.read_bytes()[:5000])
    assert_one_line_error(run_cli("dataset", command, str(truncated)), "truncated")
    import h5py

    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = [1, 2, 3]
    assert_one_line_error(run_cli("dataset", command, str(other)), "not a cocomopl")
    assert_one_line_error(run_cli("dataset", command, str(tmp_path)), "directory")


@pytest.mark.parametrize("command", [["walk"], ["simulate", "x.h5"]])
def test_feedforward_on_and_off_at_once_is_refused(tmp_path, command):
    result = run_cli(*command, "--feedforward", "--no-feedforward", "--out", str(tmp_path / "out"))
    assert_one_line_error(result, "--no-feedforward", "--feedforward")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_plot_unknown_motion(small_dataset, tmp_path):
    result = run_cli("plot", str(small_dataset), "--motion", "nope", "--out", str(tmp_path / "p"))
    assert_one_line_error(result, "no motion 'nope'")
    assert not (tmp_path / "p").exists()


@pytest.mark.slow
def test_plot_writes_four_pngs(small_dataset, tmp_path, capsys):
    assert main(["plot", str(small_dataset), "--motion", "cyclic_200_L", "--out", str(tmp_path / "p")]) == 0
    files = sorted(p.name for p in (tmp_path / "p").iterdir() if p.suffix == ".png")
    assert files == ["contact_forces.png", "joint_angles.png", "torques.png", "zmp.png"]
    assert (tmp_path / "p" / ".cocomopl-report.json").exists()  # marks the folder as a report
    for name in files:
        assert (tmp_path / "p" / name).read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow
def test_every_error_has_the_one_prefix():
    for args in (["walk", "--dt", "x"], ["model", "info", "--bogus"], ["export"], ["nope"]):
        result = run_cli(*args)
        assert result.returncode == 2 and result.stderr.startswith("cocomopl: error: "), result.stderr


def test_python_m_cocomopl_is_the_command():
    from cocomopl import __version__

    result = run_cli("--version")
    assert result.returncode == 0 and result.stdout.strip() == f"cocomopl {__version__}"


def test_help_states_units_and_the_defaults_of_the_code(capsys):
    from cocomopl.pipeline import PLAN_DT
    from cocomopl.primitives import DEFAULT_MAX_ITERATIONS

    def help_text(*command: str) -> str:
        with pytest.raises(SystemExit):
            main([*command, "--help"])
        return " ".join(capsys.readouterr().out.split())

    generate = help_text("generate")
    assert f"sample spacing of the generated walk, in s (default: {PLAN_DT:g})" in generate
    assert "--first-swing" in help_text("walk") and "--strict" in help_text("walk") and "--dt S" in help_text("walk")
    assert f"a count (default: {DEFAULT_MAX_ITERATIONS})" in help_text("train")
    dataset = help_text("dataset", "generate")
    assert "knot spacing in s" in dataset and "a count" in dataset and "in N^-2" in dataset
    assert "dataset HDF5 file" in help_text("dataset", "info")  # positional files have help


def test_model_info_names_the_dataset_without_a_path(capsys):
    from cocomopl.data import BUNDLED_MODEL

    assert main(["model", "info", "--verbose"]) == 0
    text = capsys.readouterr().out
    assert "<- best" in text  # the selection table, in text mode too
    assert main(["model", "info", "--json"]) == 0
    info = capsys.readouterr().out
    for output in (text, info):
        assert str(BUNDLED_MODEL.parent) not in output and "/data/dataset.h5" not in output
    assert json.loads(info)["dataset"]["name"] == "dataset.h5"


@pytest.mark.parametrize(
    "missing, args, extra",
    [
        (["jax"], ["train", "--kernels", "rbf"], "train"),
        (["dask", "dask.distributed"], ["dataset", "generate", "--lengths-mm", "200", "--scheduler", "tcp://127.0.0.1:9"],
         "cluster"),
    ],
)
def test_a_missing_extra_is_named_in_one_line(monkeypatch, tmp_path, capsys, missing, args, extra):
    for module in missing:  # as if the extra were not installed
        monkeypatch.setitem(sys.modules, module, None)
    assert main([*args, "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err
    assert error.startswith("cocomopl: error: ") and f"[{extra}] extra" in error and len(error.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("option, words", [
    (["--sim-model", "missing.xml"], ["--sim-model", "no file"]),
    (["--sim-model", "bad.xml"], ["bad.xml", "not a MuJoCo model"]),
    (["--kp-scale", "knee=0.5"], ["servo group 'knee'"]),
    (["--kp-scale", "legs=x"], ["--kp-scale", "'x' is not a number"]),
    (["--kv-time-s", "-0.1"], ["kv time constant -0.1"]),
    (["--latency-ms", "500"], ["latency 0.5 s"]),
    (["--encoder-noise-mrad", "nan"], ["--encoder-noise-mrad"]),
])
def test_bad_simulation_models_and_servo_settings(tmp_path, monkeypatch, option, words):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.xml").write_text("<mujoco><worldbody>")
    from cocomopl.data import BUNDLED_DATASET

    result = run_cli("simulate", str(BUNDLED_DATASET), "--motion", "start_250_L", *option, "--out", "m.h5")
    assert_one_line_error(result, *words)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.xml"]


# ---------------------------------------------------------------------------- values that start with a minus sign
def test_a_negative_value_is_a_value_not_an_option():
    import math

    from cocomopl.cli import build_parser
    from cocomopl.options import negative_values_joined

    parser = build_parser()
    argv = ["walk", "--to", "-0.6,0.3,45", "--to", "-.5,-1,-90", "--json", "--lengths-mm", "-x"]
    assert negative_values_joined(parser, argv) == ["walk", "--to=-0.6,0.3,45", "--to=-.5,-1,-90", "--json",
                                                    "--lengths-mm", "-x"]  # "-x" is no number: left to argparse
    args = parser.parse_args(negative_values_joined(parser, ["walk", "--to", "-0.6,0.3,45"]))
    assert args.to == [(-0.6, 0.3, math.radians(45))]


@pytest.mark.slow
def test_a_negative_length_gets_the_same_line_as_written_with_an_equals_sign(tmp_path):
    spaced = run_cli("generate", "--lengths-mm", "-250,250,250", "--out", str(tmp_path / "w.h5"))
    joined = run_cli("generate", "--lengths-mm=-250,250,250", "--out", str(tmp_path / "w.h5"))
    assert_one_line_error(spaced, "'-250'", "positive")
    assert spaced.stderr == joined.stderr and spaced.returncode == joined.returncode == 2
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------- help, robot names
def test_help_never_breaks_an_anchor_or_a_path(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")  # argparse wraps to the terminal's width
    for command in (["walk"], ["generate"], ["dataset", "generate"], ["simulate", "x.h5"], ["refine", "x.h5"]):
        with pytest.raises(SystemExit):
            main([*command, "--help"])
        lines = capsys.readouterr().out.splitlines()
        assert not [line for line in lines if line.rstrip().endswith("-") and not line.rstrip().endswith(" -")], command
    with pytest.raises(SystemExit):
        main(["walk", "--help"])
    assert "docs/method.md#footstep-planner" in capsys.readouterr().out


@pytest.mark.slow
def test_robot_names_are_case_insensitive(tmp_path):
    result = run_cli("dataset", "generate", "--robot", "TALOS", "--lengths-mm", "150,700", "--out", str(tmp_path / "d.h5"))
    assert_one_line_error(result, "700 mm", "beyond talos's reach")  # Talos, not an unknown robot
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------- Ctrl-C while the libraries load
INTERRUPTED_AT_IMPORT = """
import builtins, os, runpy, signal, sys

real_import = builtins.__import__


def interrupting_import(name, *args, **kwargs):
    if name == {module!r}:
        builtins.__import__ = real_import
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C, delivered while the module loads
    return real_import(name, *args, **kwargs)


# Python's own Ctrl-C handler, also where the tests run with SIGINT ignored (nohup, a background job)
signal.signal(signal.SIGINT, signal.default_int_handler)
builtins.__import__ = interrupting_import
sys.argv = ["cocomopl", "generate", "--out", {out!r}]
runpy.run_module("cocomopl", run_name="__main__", alter_sys=True)
"""


@pytest.mark.slow
@pytest.mark.parametrize("module", ["argparse", "numpy", "cocomopl.pipeline"])
def test_ctrl_c_while_the_libraries_load_is_one_line(tmp_path, module):
    import subprocess

    out = tmp_path / "walk.h5"
    code = INTERRUPTED_AT_IMPORT.format(module=module, out=str(out))
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert result.returncode == 130, result.stderr
    assert result.stderr == "cocomopl: interrupted\n"
    assert list(tmp_path.iterdir()) == []
