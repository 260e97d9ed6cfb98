"""``reach batch`` and the network: a plain ``tcp://`` scheduler address beyond loopback is
refused with one line, before any connection is tried (a listening socket the address
leads to sees none; with ``--insecure-network`` it does); a ``tls://`` address needs a CA
and a certificate; a TLS scheduler refuses a client without the cluster's certificate.
And the stop: SIGTERM stops a study with one line saying what finished and what did not,
every result file whole, no worker left running, and a re-run does the rest."""

import json
import signal
import socket
import ssl
import subprocess
import sys
import threading
import time

import dask_tls
import pytest
import rigs

ROOT = dask_tls.ROOT
RUN_TIMEOUT = 300

STUDY = """
name = "stop-test"
arm = "right"
settings = {{ grid_cells = 9 }}

[[scenes]]
file = "plate.blend"
armature = "{armature}"
[scenes.grid]
frame = "shoulder"
min = [0.3, -0.2, -0.3]
max = [0.8, 0.4, 0.3]
count = [2, 2, 2]
"""


def batch(*argv, timeout=RUN_TIMEOUT, **env):
    return subprocess.run([sys.executable, "-m", "reach_addon", "batch", *map(str, argv)],
                          capture_output=True, text=True, env=dask_tls.env(**env),
                          timeout=timeout, cwd=ROOT)


def refused(run):
    """The run ended with status 2 and one line on stderr; returns that line."""
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 2 and len(lines) == 1, run.stdout + run.stderr
    assert lines[0].startswith("reach: ")
    return lines[0]


@pytest.fixture(scope="module")
def study(addon, tmp_path_factory):
    folder = tmp_path_factory.mktemp("stop-study")
    scene = rigs.save_cli_scene("metarig", addon.blender.rig, folder / "plate.blend")
    path = folder / "study.toml"
    path.write_text(STUDY.format(armature=scene["armature"]))
    return path


@pytest.fixture(scope="module")
def certs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("certs")
    return {"farm": dask_tls.make_certs(folder, "farm"),
            "other": dask_tls.make_certs(folder, "other")}   # another CA's certificate


class Listener:
    """A TCP server on 127.0.0.1 that counts the connections it is offered (and closes
    each at once)."""

    def __init__(self):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen()
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.count = 0
        self.running = True
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while self.running:
            try:
                conn, _ = self.sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            self.count += 1
            conn.close()

    def close(self):
        self.running = False
        self.thread.join(timeout=5)
        self.sock.close()


def raw_tls(address, ca, certs):
    """The first bytes a TLS scheduler sends a TLS client that trusts ``ca`` and shows the
    certificate of ``certs`` (None: no certificate); b"" if it closes cleanly. A Dask
    server sends its handshake first."""
    host, port = address.removeprefix("tls://").split(":")
    context = ssl.create_default_context(cafile=str(ca))
    context.check_hostname = False
    if certs:
        context.load_cert_chain(str(certs["cert"]), str(certs["key"]))
    with socket.create_connection((host, int(port)), timeout=30) as raw:
        with context.wrap_socket(raw) as conn:
            return conn.recv(8)


@pytest.fixture
def listener():
    server = Listener()
    yield server
    server.close()


def test_plain_tcp_beyond_loopback_is_refused_before_any_connection(study, listener, tmp_path):
    """``tcp://0.0.0.0:PORT`` leads, on Linux, to the listener on 127.0.0.1:PORT, but it
    is no loopback address: refused with the one line, no connection made, nothing
    written. With --insecure-network the same command does connect (and fails there: the
    listener is no scheduler)."""
    address = f"tcp://0.0.0.0:{listener.port}"
    out = tmp_path / "out"
    line = refused(batch(study, "--dask", address, "--output", out))
    assert line.startswith(f"reach: refusing --dask {address}: a plain connection is neither "
                           "encrypted nor authenticated"), line
    assert "anyone who can reach that port can run any code" in line
    assert "--insecure-network" in line and "tls://" in line
    host_only = refused(batch(study, "--dask", f"0.0.0.0:{listener.port}", "--output", out))
    assert "--insecure-network" in host_only          # no scheme: Dask's default, tcp
    assert listener.count == 0 and not out.exists()

    line = refused(batch(study, "--dask", address, "--insecure-network", "--output", out))
    assert line.startswith(f"reach: cannot reach the Dask scheduler at {address}"), line
    assert listener.count >= 1, "the address did not lead to the listener"
    assert not out.exists()


#: Dask's TLS settings unset, whatever a configuration file of this machine says.
NO_TLS_CONFIG = {f"DASK_DISTRIBUTED__COMM__TLS__{key}": "None"
                 for key in ("CA_FILE", "CLIENT__CERT", "CLIENT__KEY")}


def test_tls_needs_its_files(tmp_path):
    """A tls:// address without a CA and certificate (no flags, no Dask configuration),
    with a file that is not there, or with TLS flags on a plain address: one line naming
    what to give, before the study is read (it does not exist here)."""
    missing = tmp_path / "no-study.toml"
    line = refused(batch(missing, "--dask", "tls://127.0.0.1:8786", **NO_TLS_CONFIG))
    for name in ("--tls-ca-file", "--tls-cert", "--tls-key", "distributed.comm.tls.ca-file",
                 "distributed.comm.tls.client.cert"):
        assert name in line, line
    line = refused(batch(missing, "--dask", "tls://127.0.0.1:8786", "--tls-ca-file",
                         tmp_path / "ca.pem", "--tls-cert", tmp_path / "cert.pem"))
    assert "--tls-ca-file: file" in line and "ca.pem' not found" in line
    line = refused(batch(missing, "--dask", "tcp://127.0.0.1:8786", "--tls-cert",
                         tmp_path / "cert.pem"))
    assert "plain tcp:// address" in line


def test_a_tls_scheduler_refuses_clients_without_the_cluster_certificate(study, certs, tmp_path):
    """A TLS scheduler on loopback (no workers needed): a TLS client with the cluster's CA
    but no certificate of its own is refused in the handshake; ``reach batch`` with a
    certificate signed by another CA exits 2 with one line, and so does a plain tcp://
    client; with the cluster's certificate the same command line connects."""
    farm, other = certs["farm"], certs["other"]
    with dask_tls.cluster(tmp_path / "cluster", farm, workers=0) as address:
        assert raw_tls(address, farm["ca"], farm) != b"", "the scheduler says nothing"
        with pytest.raises((ssl.SSLError, ConnectionError)):    # TLS 1.3: at first read
            raw_tls(address, farm["ca"], None)

        out = tmp_path / "out"
        line = refused(batch(study, "--dask", address, *dask_tls.tls_flags(other),
                             "--output", out, timeout=120))
        assert line.startswith(f"reach: the Dask scheduler at {address} and this client did "
                               "not accept each other's TLS certificates"), line
        line = refused(batch(study, "--dask", address.replace("tls://", "tcp://"),
                             "--output", out, timeout=120))
        assert "cannot reach the Dask scheduler" in line, line
        assert not out.exists()

        from distributed import Client

        with Client(address, security=dask_tls.security(farm), timeout=30) as client:
            assert client.scheduler_info()["address"] == address


def test_sigterm_stops_a_study_with_one_line_and_whole_results(study, tmp_path):
    """SIGTERM to ``reach batch`` after two results: status 143, one line on stderr saying
    how many results were written and how many tasks are not done (the counts of the
    files), every result file whole JSON of its task, no temporary file and no summary,
    no process of the run left; a re-run plans only the tasks not done."""
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "reach_addon", "batch", str(study), "--workers", "2",
         "--output", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dask_tls.env(),
        cwd=ROOT, start_new_session=True)
    watchdog = threading.Timer(RUN_TIMEOUT, lambda: dask_tls.end_group(proc, timeout=5))
    watchdog.start()
    try:
        seen = []
        for line in proc.stdout:
            seen.append(line)
            if line.startswith("[2/8]"):
                break
        assert seen and seen[-1].startswith("[2/8]"), "".join(seen) + proc.stderr.read()
        proc.send_signal(signal.SIGTERM)
        t0 = time.monotonic()
        stdout, stderr = proc.communicate(timeout=60)
        stopped_in = time.monotonic() - t0
        deadline = time.monotonic() + 15
        while dask_tls.group_alive(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.2)
        left = dask_tls.group_alive(proc.pid)
    finally:
        watchdog.cancel()
        dask_tls.end_group(proc, timeout=5)
    stdout = "".join(seen) + stdout
    assert proc.returncode == 128 + signal.SIGTERM, stdout + stderr
    assert stopped_in < 20.0
    assert left == [], "Reach worker processes outlived the run"

    files = sorted((out / "tasks").glob("*.json"))
    written = len([line for line in stdout.splitlines() if line.startswith("[")])
    assert 2 <= written == len(files) < 8, stdout
    for path in files:
        result = json.loads(path.read_text())
        assert result["id"] == path.stem and "success" in result
    assert not [p for p in out.rglob("*") if ".tmp" in p.name]
    assert not (out / "summary.json").exists() and not (out / "summary.csv").exists()
    lines = stderr.strip().splitlines()
    assert lines == [f"reach: stopped by SIGTERM; {written} task result(s) written by this "
                     f"run ({written} of 8 tasks done in '{out / 'tasks'}'), {8 - written} "
                     "not done: a re-run plans only those; no summary written"], stderr

    before = {p.name: p.stat().st_mtime_ns for p in files}
    run = batch(study, "--workers", 2, "--output", out)
    assert run.returncode in (0, 1), run.stdout + run.stderr
    assert f"8 tasks, {written} already done, {8 - written} to run" in run.stdout, run.stdout
    assert len(list((out / "tasks").glob("*.json"))) == 8
    assert {p.name: p.stat().st_mtime_ns for p in files} == before
    assert json.loads((out / "summary.json").read_text())["tasks"] == 8
