"""benchmarks/run_all.py's --busy: the load it makes is there while it runs, and always stopped."""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def run_all():
    spec = importlib.util.spec_from_file_location("run_all", ROOT / "benchmarks" / "run_all.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_busy_processes_run_inside_and_stop_after(run_all):
    with run_all.busy(2) as procs:
        assert len(procs) == 2
        assert all(p.poll() is None for p in procs)  # still running
    assert all(p.poll() is not None for p in procs)


def test_busy_processes_stop_when_the_block_fails(run_all):
    with pytest.raises(RuntimeError, match="a benchmark failed"), run_all.busy(1) as procs:
        raise RuntimeError("a benchmark failed")
    assert procs[0].poll() is not None


def test_busy_zero_starts_nothing(run_all):
    with run_all.busy(0) as procs:
        assert procs == []


def test_negative_busy_is_refused(run_all, monkeypatch, capsys, tmp_path):
    monkeypatch.setattr("sys.argv", ["run_all.py", "--out", str(tmp_path), "--busy", "-1"])
    with pytest.raises(SystemExit) as info:
        run_all.main()
    assert info.value.code == 2
    assert "--busy must be 0 or more, got -1" in capsys.readouterr().err
