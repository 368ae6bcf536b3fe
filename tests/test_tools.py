"""tools/compare_csv.py and tools/check_settled.py, which ctest's paper.* tests rely on, and the
test-time plugin tools/cpu_per_test.py."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HEADER = "t,theta0,theta1,dtheta0,dtheta1\n"


def tool(name: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "tools" / name), *args], capture_output=True, text=True)


def test_compare_csv_names_the_worst_column_and_row(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text(HEADER + "0,0,0,0,0\n0.5,1,2,3,4\n")
    b.write_text(HEADER + "0,0,0,0,1e-9\n0.5,1,2.001,3,4\n")
    ok = tool("compare_csv.py", str(a), str(b), "--tol", "1e-2")
    assert ok.returncode == 0 and "max |difference| 1.000e-03" in ok.stdout
    failed = tool("compare_csv.py", str(a), str(b), "--tol", "1e-6")
    assert failed.returncode == 1
    assert "column theta1, row 2 (t = 0.5): 2 vs 2.0009999999999999" in failed.stdout


def test_compare_csv_refuses_different_shapes(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text(HEADER + "0,0,0,0,0\n")
    b.write_text(HEADER + "0,0,0,0,0\n1,0,0,0,0\n")
    result = tool("compare_csv.py", str(a), str(b), "--tol", "1")
    assert result.returncode == 2 and "1 rows vs 2 rows" in result.stderr


def test_check_settled_accepts_hanging_down_either_way(tmp_path: Path) -> None:
    run = tmp_path / "run.csv"
    run.write_text(HEADER + f"30,5,{-math.pi + 1e-4},1e-4,-1e-4\n")
    assert tool("check_settled.py", str(run), "--angle-tol", "1e-3", "--rate-tol", "1e-3").returncode == 0
    run.write_text(HEADER + f"30,5,{3 * math.pi},0,0\n")
    assert tool("check_settled.py", str(run), "--angle-tol", "1e-3", "--rate-tol", "1e-3").returncode == 0


def test_check_settled_reports_what_is_not_settled(tmp_path: Path) -> None:
    run = tmp_path / "run.csv"
    run.write_text(HEADER + "30,5,3.1,2e-3,0\n")
    result = tool("check_settled.py", str(run), "--angle-tol", "1e-3", "--rate-tol", "1e-3")
    assert result.returncode == 1
    assert "theta1 is 4.159e-02 rad from ±π" in result.stdout and "|dtheta0| = 2.000e-03" in result.stdout


def test_cpu_per_test_counts_a_tests_subprocesses_apart_from_its_own_time(tmp_path: Path) -> None:
    (tmp_path / "test_busy.py").write_text(
        "import subprocess, sys\n"
        "def test_spawns():\n"
        "    subprocess.run([sys.executable, '-c', 'sum(i * i for i in range(3_000_000))'], check=True)\n"
        "def test_idle():\n"
        "    pass\n"
    )
    log = tmp_path / "cpu.log"
    env = {key: value for key, value in os.environ.items() if key != "PYTEST_ADDOPTS"}
    env.update(PYTHONPATH=str(ROOT / "tools"), CPU_LOG=str(log))
    command = [sys.executable, "-m", "pytest", "-q", "-p", "cpu_per_test", "-p", "no:cacheprovider"]
    command.append("test_busy.py")
    done = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    rows = {line.split()[4]: [float(x) for x in line.split()[:4]] for line in log.read_text().splitlines()}
    assert set(rows) == {"test_busy.py::test_spawns", "test_busy.py::test_idle"}
    assert rows["test_busy.py::test_spawns"][1] > 0.05  # the child's CPU time, counted as children
    assert rows["test_busy.py::test_idle"][1] == 0.0
