"""The Python module against the command line: the same program read, compensated and calibrated
through `import postproc` must give what `postproc dump`, `postproc compensate` and `postproc
calibrate` give (run by ctest as `python3 -m pytest`, with PYTHONPATH at the built module and
POSTPROC_CLI / POSTPROC_SOURCE_DIR set)."""
import csv
import json
import math
import os
import subprocess

import numpy as np
import pytest

import postproc

CLI = os.environ["POSTPROC_CLI"]
SRC = os.environ["POSTPROC_SOURCE_DIR"]
PROGRAMS = os.path.join(SRC, "samples", "programs")
MACHINES = os.path.join(SRC, "samples", "machines")
MEASUREMENTS = os.path.join(SRC, "samples", "measurements")


def cli(*args):
    return subprocess.run([CLI, *args], check=True, capture_output=True, text=True)


def test_version_is_the_command_line_s():
    assert postproc.__version__ in cli("--version").stdout


@pytest.mark.parametrize("program,dialect", [("impeller_axes_bc.nc", "fanuc"), ("housing_traori.mpf", "siemens"),
                                             ("freeform_lathe_macro.ngc", "linuxcnc")])
def test_read_equals_dump(tmp_path, program, dialect):
    path = os.path.join(PROGRAMS, program)
    got = postproc.read(path, dialect=dialect)
    assert got["dialect"] == dialect
    out = tmp_path / "dump.csv"
    cli("dump", path, "--dialect", dialect, "-o", str(out))
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == len(got["line"]) > 5
    assert isinstance(got["x"], np.ndarray) and got["x"].dtype == np.float64
    for i, row in enumerate(rows):
        assert int(row["line"]) == got["line"][i]
        assert row["motion"] == got["type"][i]
        for axis in "xyzabc":
            if row[axis] == "":
                assert math.isnan(got[axis][i])
            else:
                assert got[axis][i] == pytest.approx(float(row[axis]), abs=1e-9)


def test_read_guesses_the_dialect_and_refuses_with_the_line(tmp_path):
    assert postproc.read(os.path.join(PROGRAMS, "housing_traori.mpf"))["dialect"] == "siemens"
    bad = tmp_path / "bad.nc"
    bad.write_text("%\nO1\nG1 X1 Y2 F100\nG2 X5 Y5 R1\nM30\n%\n")
    with pytest.raises(postproc.Refused) as e:
        postproc.read(str(bad), dialect="fanuc")
    assert "bad.nc:4:" in str(e.value)
    assert any(":4:" in d for d in e.value.diagnostics)
    with pytest.raises(ValueError):
        postproc.read(str(bad), dialect="fanuk")


def test_compensate_equals_the_command(tmp_path):
    path = os.path.join(PROGRAMS, "impeller_axes_bc.nc")
    machine = os.path.join(MACHINES, "trunnion_bc_fanuc.toml")
    got = postproc.compensate(path, machine)
    out, rep = tmp_path / "c.nc", tmp_path / "c.json"
    cli("compensate", path, "-m", machine, "-o", str(out), "--json", str(rep))
    assert got["program"] == out.read_text()
    want = json.load(open(rep))["figures"]
    assert got["figures"]["figures"]["max_error_before_mm"] == pytest.approx(want["max_error_before_mm"], rel=1e-12)
    assert got["figures"]["figures"]["max_residual_after_mm"] < 0.1 * want["max_error_before_mm"]
    with pytest.raises(ValueError):
        postproc.compensate(path, machine, mode="sideways")


def test_compensate_refuses_a_program_the_machine_cannot_reach(tmp_path):
    bad = tmp_path / "far.nc"
    bad.write_text("%\nO1\nG21 G90 G54\nG0 X0 Y0 Z50 B0 C0\nG1 X90000 F100\nM30\n%\n")
    with pytest.raises(postproc.Refused) as e:
        postproc.compensate(str(bad), os.path.join(MACHINES, "trunnion_bc_fanuc.toml"))
    assert e.value.diagnostics and "far.nc:5:" in e.value.diagnostics[0]


def test_calibrate_equals_the_command(tmp_path):
    data = os.path.join(MEASUREMENTS, "trunnion_bc_positions.csv")
    machine = os.path.join(MACHINES, "trunnion_bc_fanuc_nominal.toml")
    got = postproc.calibrate([data], machine)
    rep = tmp_path / "cal.json"
    cli("calibrate", data, "-m", machine, "-o", str(tmp_path / "cal.toml"), "--json", str(rep), "-j", "1")
    want = json.load(open(rep))
    by_name = {p["name"]: p for p in want["parameters"]}
    assert len(got["parameters"]) == len(by_name) > 5
    for p in got["parameters"]:
        q = by_name[p["name"]]
        assert p["status"] == q["status"]
        if p["value"] is not None:
            assert p["value"] == pytest.approx(q["value"], abs=1e-9, rel=1e-6)
    assert got["figures"]["fit"]["max_position_after_mm"] < 0.2 * got["figures"]["fit"]["max_position_before_mm"]
