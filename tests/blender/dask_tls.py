"""A Dask cluster on loopback for the batch tests, started as the README's recipe starts
one: certificates made with the recipe's ``openssl`` commands, a scheduler and workers with
``--tls-ca-file``, ``--tls-cert`` and ``--tls-key``, bound to 127.0.0.1 with ``--host`` and
``--dashboard-address`` — and checked: every socket the cluster listens on is on 127.0.0.1.

Every process is started in a new session (its own process group), so the scheduler, the
workers' nannies, the Dask workers and the Reach worker children under them are all ended
together, by the group's id, when the cluster closes — also when a test fails or the
cluster does not start. Every wait has a deadline."""

import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BINDIR = Path(sys.executable).parent
OPENSSL_TIMEOUT = 60
START_TIMEOUT = 120


def env(**extra):
    """The environment of the command line and the cluster: this checkout importable, no
    ``DASK_*`` variables but those in ``extra`` (Dask still reads its YAML files, e.g.
    ``~/.config/dask/``: the tests give every TLS setting they rely on)."""
    out = {k: v for k, v in os.environ.items() if not k.startswith("DASK_")}
    out.update(PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1", **extra)
    return out


def openssl(*argv, cwd):
    subprocess.run(["openssl", *argv], cwd=cwd, check=True, timeout=OPENSSL_TIMEOUT,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def make_certs(folder: Path, name: str = "farm") -> dict:
    """A CA ``<name>-ca.pem`` and a key and certificate signed by it, ``<name>.key`` and
    ``<name>.pem``, in ``folder`` — the README's commands. Returns the three paths:
    ``{"ca", "cert", "key"}``."""
    folder.mkdir(parents=True, exist_ok=True)
    openssl("req", "-x509", "-newkey", "rsa:3072", "-nodes", "-days", "365", "-subj",
            f"/CN=reach {name} CA", "-keyout", f"{name}-ca.key", "-out", f"{name}-ca.pem",
            cwd=folder)
    openssl("req", "-newkey", "rsa:3072", "-nodes", "-subj", f"/CN=reach {name}", "-keyout",
            f"{name}.key", "-out", f"{name}.csr", cwd=folder)
    openssl("x509", "-req", "-in", f"{name}.csr", "-CA", f"{name}-ca.pem", "-CAkey",
            f"{name}-ca.key", "-CAcreateserial", "-days", "365", "-out", f"{name}.pem",
            cwd=folder)
    return {"ca": folder / f"{name}-ca.pem", "cert": folder / f"{name}.pem",
            "key": folder / f"{name}.key"}


def tls_flags(certs: dict) -> list:
    """The three flags of ``reach batch`` and of ``dask scheduler`` / ``dask worker``."""
    return ["--tls-ca-file", str(certs["ca"]), "--tls-cert", str(certs["cert"]),
            "--tls-key", str(certs["key"])]


def security(certs: dict):
    """A test client's ``Security`` with these files."""
    from distributed.security import Security

    return Security(require_encryption=True, tls_ca_file=str(certs["ca"]),
                    tls_client_cert=str(certs["cert"]), tls_client_key=str(certs["key"]))


def free_port():
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def end_group(proc, timeout=30):
    """End ``proc`` and every process in its group: SIGTERM, then SIGKILL at ``timeout``."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            pass
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and group_alive(proc.pid):
            proc.poll()
            time.sleep(0.2)
        if not group_alive(proc.pid):
            break
    try:
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        pass


def _hex_ip(text: str) -> str:
    """An address of /proc/net/tcp{,6} (host byte order, 32-bit words) as text."""
    import ipaddress
    import struct

    raw = bytes.fromhex(text)
    words = struct.unpack(f"<{len(raw) // 4}I", raw)
    return str(ipaddress.ip_address(struct.pack(f">{len(words)}I", *words)))


def listening(pgids) -> list:
    """(address, port) of every TCP socket that a process in the groups ``pgids`` listens
    on (IPv4-mapped addresses as IPv4)."""
    import ipaddress

    inodes = set()
    for pgid in pgids:
        for pid in group_alive(pgid):
            for fd in Path(f"/proc/{pid}/fd").glob("*"):
                try:
                    target = os.readlink(fd)
                except OSError:
                    continue
                if target.startswith("socket:["):
                    inodes.add(target[8:-1])
    out = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:      # LISTEN
                host, port = fields[1].split(":")
                ip = ipaddress.ip_address(_hex_ip(host))
                mapped = getattr(ip, "ipv4_mapped", None)
                out.append((str(mapped or ip), int(port, 16)))
    return sorted(out)


def group_alive(pgid: int) -> list:
    """The ids of the live (not zombie) processes in process group ``pgid``."""
    alive = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:
            continue
        fields = text[text.rindex(")") + 2:].split()
        if fields[0] != "Z" and int(fields[2]) == pgid:
            alive.append(int(stat.parent.name))
    return alive


@contextmanager
def cluster(folder: Path, certs: dict | None, workers: int = 2):
    """A scheduler on 127.0.0.1 and ``workers`` Dask worker processes (one thread each),
    with TLS from ``certs`` (None: plain tcp). Yields the scheduler's address once every
    worker has registered and every socket of the cluster listens on 127.0.0.1 alone; the
    logs are ``folder/scheduler.log`` and ``folder/workers.log``."""
    dask = BINDIR / "dask"
    assert dask.exists(), ("the dask command is missing: pip install 'dask[distributed]' "
                           "(it is in requirements-dev.txt; run make setup)")
    folder.mkdir(parents=True, exist_ok=True)
    port = free_port()
    scheme = "tls" if certs else "tcp"
    address = f"{scheme}://127.0.0.1:{port}"
    flags = tls_flags(certs) if certs else []
    procs = []
    logs = {}

    def start(name, argv):
        log = logs[name] = folder / f"{name}.log"
        with open(log, "w") as fh:
            procs.append(subprocess.Popen([str(dask), *argv], env=env(), stdout=fh,
                                          stderr=subprocess.STDOUT, start_new_session=True))

    def tail():
        return "\n".join(f"--- {p.name}\n" + p.read_text()[-3000:] for p in logs.values())

    try:
        start("scheduler", ["scheduler", "--host", "127.0.0.1", "--port", str(port),
                            "--dashboard-address", "127.0.0.1:0", *flags])
        if workers:
            start("workers", ["worker", address, "--host", "127.0.0.1", "--nworkers",
                              str(workers), "--nthreads", "1",
                              "--dashboard-address", "127.0.0.1:0",
                              "--local-directory", str(folder / "scratch"), *flags])
        from distributed import Client

        deadline = time.monotonic() + START_TIMEOUT
        with Client(address, security=security(certs) if certs else None,
                    timeout=START_TIMEOUT) as client:
            while len(client.scheduler_info()["workers"]) < workers:
                assert time.monotonic() < deadline, "the Dask workers did not start\n" + tail()
                assert all(p.poll() is None for p in procs), "a Dask process ended\n" + tail()
                time.sleep(0.5)
        bound = listening([proc.pid for proc in procs])
        assert ("127.0.0.1", port) in bound, bound
        assert {host for host, _ in bound} == {"127.0.0.1"}, bound
        yield address
    finally:
        for p in reversed(procs):
            end_group(p)
