"""Batch studies: a reach-envelope study of ≥ 20 tasks on 2 local worker processes and on a
real Dask scheduler with 2 workers (subprocesses on loopback) gives the same results; a
re-run redoes only the missing results."""

import csv
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rigs

ROOT = Path(__file__).resolve().parents[2]
TIMING = {"search_time_s", "preprocess_time_s", "planning_time_s", "wall_time_s"}

STUDY = """
name = "plate-envelope"
arm = "right"
settings = {{ grid_cells = 9 }}

[[variants]]
name = "with-body"
[[variants]]
name = "no-body"
settings = {{ chest_rotation = false }}

[[scenes]]
file = "{scene}"
armature = "{armature}"
targets = ["Cup", "Inside"]
[scenes.grid]
frame = "shoulder"
min = [0.3, -0.2, -0.3]
max = [0.8, 0.4, 0.3]
count = [2, 2, 3]
"""


def env():
    return dict(os.environ, PYTHONPATH=str(ROOT))


def batch(*argv, timeout=900):
    return subprocess.run([sys.executable, "-m", "reach_addon", "batch", *map(str, argv)],
                          capture_output=True, text=True, env=env(), timeout=timeout, cwd=ROOT)


def results(folder):
    out = {}
    for path in sorted((folder / "tasks").glob("*.json")):
        r = json.loads(path.read_text())
        out[path.stem] = {k: v for k, v in r.items() if k not in TIMING}
    return out


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def dask_cluster():
    """A Dask scheduler and one worker command with 2 worker processes, on loopback."""
    bindir = Path(sys.executable).parent
    if not (bindir / "dask").exists():
        pytest.fail("the dask command is missing: pip install 'dask[distributed]' "
                    "(it is in requirements-dev.txt; run make setup)")
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = [subprocess.Popen([bindir / "dask", "scheduler", "--host", "127.0.0.1", "--port",
                               str(port), "--no-dashboard"], env=env(),
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    procs.append(subprocess.Popen([bindir / "dask", "worker", address, "--nworkers", "2",
                                   "--nthreads", "1", "--no-dashboard"], env=env(),
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    from distributed import Client

    deadline = time.monotonic() + 120
    with Client(address, timeout=60) as client:
        while len(client.scheduler_info()["workers"]) < 2:
            assert time.monotonic() < deadline, "the Dask workers did not start"
            time.sleep(0.5)
    yield address
    for p in reversed(procs):
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            p.kill()


@pytest.fixture(scope="module")
def study(addon, tmp_path_factory):
    folder = tmp_path_factory.mktemp("study")
    scene = rigs.save_cli_scene("metarig", addon.blender.rig, folder / "plate.blend")
    path = folder / "study.toml"
    path.write_text(STUDY.format(scene="plate.blend", armature=scene["armature"]))
    return path


def test_local_and_dask_runs_agree_and_a_rerun_redoes_only_missing_results(study, dask_cluster):
    local, remote = study.parent / "local", study.parent / "dask"
    run = batch(study, "--workers", 2, "--output", local)
    assert run.returncode == 1, run.stdout + run.stderr   # "Inside" cannot be reached
    lines = run.stdout.splitlines()
    assert lines[0].endswith("28 tasks, 0 already done, 28 to run on 2 local workers")
    assert len([line for line in lines if line.startswith("[")]) == 28
    first = results(local)
    assert len(first) == 28

    summary = json.loads((local / "summary.json").read_text())
    rows = list(csv.DictReader((local / "summary.csv").open()))
    assert summary["tasks"] == len(rows) == 28
    ok = [r for r in first.values() if r["success"]]
    assert summary["succeeded"] == len(ok) and 0 < len(ok) < 28
    assert sum(summary["final_strength_categories"]) == len(ok)
    assert set(summary["variants"]) == {"with-body", "no-body"}
    inside = [r for r in first.values() if r["target"] == "Inside"]
    assert len(inside) == 2 and all(r["reason"] == "target_in_obstacle" for r in inside)
    for r in ok:
        assert r["wrist_error_arm_lengths"] <= 0.005
        assert r["final_f_r"] in (0, 1, 2)
        if r["variant"] == "no-body":
            assert r["final_angles_deg"]["body_rotation"] == 0.0

    run = batch(study, "--dask", dask_cluster, "--output", remote)
    assert run.returncode == 1, run.stdout + run.stderr
    assert "Dask cluster" in run.stdout.splitlines()[0]
    assert results(remote) == first

    # delete half the local results: a re-run plans exactly those again
    paths = sorted((local / "tasks").glob("*.json"))
    kept = {p.name: p.stat().st_mtime_ns for p in paths[::2]}
    for p in paths[1::2]:
        p.unlink()
    run = batch(study, "--workers", 2, "--output", local)
    assert "28 tasks, 14 already done, 14 to run" in run.stdout, run.stdout
    assert len([line for line in run.stdout.splitlines() if line.startswith("[")]) == 14
    assert {p.name: p.stat().st_mtime_ns for p in paths[::2]} == kept
    assert results(local) == first


def test_a_bad_study_exits_2_naming_the_problem(study, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(study.read_text().replace('file = "plate.blend"', 'file = "gone.blend"'))
    run = batch(bad)
    assert run.returncode == 2
    assert run.stderr.strip().startswith("reach: ") and "gone.blend" in run.stderr
    assert not (tmp_path / "bad-results").exists()
    bad.write_text("name = 3 = 4")
    run = batch(bad)
    assert run.returncode == 2 and "not valid TOML" in run.stderr
