"""Batch studies: a reach-envelope study of ≥ 20 tasks on 2 local worker processes and on a
real Dask scheduler with 2 workers (subprocesses on loopback, every connection TLS with
certificates the test makes, as the README's recipe does) gives the same results; the TLS
settings work from the flags and from Dask's configuration; a re-run redoes only the
missing results."""

import csv
import json
import subprocess
import sys

import dask_tls
import pytest
import rigs

ROOT = dask_tls.ROOT
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


def batch(*argv, timeout=900, **env):
    return subprocess.run([sys.executable, "-m", "reach_addon", "batch", *map(str, argv)],
                          capture_output=True, text=True, env=dask_tls.env(**env),
                          timeout=timeout, cwd=ROOT)


def results(folder):
    out = {}
    for path in sorted((folder / "tasks").glob("*.json")):
        r = json.loads(path.read_text())
        out[path.stem] = {k: v for k, v in r.items() if k not in TIMING}
    return out


@pytest.fixture(scope="module")
def certs(tmp_path_factory):
    return dask_tls.make_certs(tmp_path_factory.mktemp("certs"))


@pytest.fixture
def dask_cluster(certs, tmp_path):
    """A TLS Dask scheduler and one worker command with 2 worker processes, on loopback."""
    with dask_tls.cluster(tmp_path / "cluster", certs, workers=2) as address:
        yield address


@pytest.fixture(scope="module")
def study(addon, tmp_path_factory):
    folder = tmp_path_factory.mktemp("study")
    scene = rigs.save_cli_scene("metarig", addon.blender.rig, folder / "plate.blend")
    path = folder / "study.toml"
    path.write_text(STUDY.format(scene="plate.blend", armature=scene["armature"]))
    return path


def test_local_and_tls_dask_runs_agree_and_a_rerun_redoes_only_missing_results(
        study, certs, dask_cluster):
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

    assert dask_cluster.startswith("tls://127.0.0.1:")
    run = batch(study, "--dask", dask_cluster, *dask_tls.tls_flags(certs), "--output", remote)
    assert run.returncode == 1, run.stdout + run.stderr
    assert f"Dask cluster {dask_cluster}" in run.stdout.splitlines()[0]
    assert results(remote) == first

    # the same files from Dask's configuration instead of the flags: 3 tasks again
    for p in sorted((remote / "tasks").glob("*.json"))[:3]:
        p.unlink()
    run = batch(study, "--dask", dask_cluster, "--output", remote,
                DASK_DISTRIBUTED__COMM__TLS__CA_FILE=str(certs["ca"]),
                DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT=str(certs["cert"]),
                DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY=str(certs["key"]))
    assert "28 tasks, 25 already done, 3 to run on Dask cluster" in run.stdout, \
        run.stdout + run.stderr
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
