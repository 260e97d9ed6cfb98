r"""Batch studies on a Dask distributed cluster: how to connect safely
(:func:`dask_security`), connecting (:func:`connect`) and running the tasks there
(:func:`run_on_cluster`): each Dask worker process keeps one Reach worker child
(:func:`.batch_workers.dask_task`), so the work done per task is the local one.

Every machine needs Python 3.11, the bpy wheel, numpy, dask[distributed] and Reach
importable — the scheduler too, it unpickles the task graph — and the scene files at the
same paths. Every connection uses TLS, each side showing a certificate of the farm's own
CA; a plain ``tcp://`` address beyond the loopback is refused unless
``insecure_network`` accepts the risk. With a CA ``farm-ca.pem`` and a key and certificate
signed by it, ``farm.key`` and ``farm.pem`` (the README's ``openssl`` commands make them),
``SCHED`` the scheduler's address on the farm network and ``ME`` each worker machine's
own (both 127.0.0.1 for a trial on one machine)::

    TLS="--tls-ca-file farm-ca.pem --tls-cert farm.pem --tls-key farm.key"
    PYTHONPATH=/path/to/reach dask scheduler --host $SCHED --port 8786 \
        --dashboard-address 127.0.0.1:8787 $TLS
    PYTHONPATH=/path/to/reach dask worker tls://$SCHED:8786 --host $ME --nworkers 4 \
        --nthreads 1 --dashboard-address 127.0.0.1:0 $TLS
    python -m reach_addon batch study.toml --dask tls://$SCHED:8786 $TLS
"""

from __future__ import annotations

from pathlib import Path

from .batch_workers import dask_task
from .core import ReachError

#: Dask's address schemes whose connections are encrypted and authenticated (TLS).
ENCRYPTED_SCHEMES = ("tls", "wss")


def is_loopback(host: str) -> bool:
    """True when ``host`` (an address's host part) is this machine's loopback interface:
    127.0.0.0/8, ::1 (or ::ffff:127.x.y.z) or ``localhost``. Other names are not looked
    up: a name is taken for a network address, whatever it resolves to."""
    import ipaddress

    if host.lower().rstrip(".") == "localhost":
        return True
    try:
        ip = ipaddress.ip_address(host)
    except ValueError:
        return False
    mapped = getattr(ip, "ipv4_mapped", None)
    return ip.is_loopback or bool(mapped and mapped.is_loopback)


def insecure_address_message(address: str) -> str:
    """The refusal of a plain (unencrypted) ``address`` that is not loopback: the risk, and
    the two ways on."""
    return (f"refusing --dask {address}: a plain connection is neither encrypted nor "
            "authenticated, and a Dask scheduler runs whatever task graph it is sent, so "
            "anyone who can reach that port can run any code on the scheduler and on "
            "every worker, as the user they run as; use tls://HOST:PORT with "
            "--tls-ca-file, --tls-cert and --tls-key (README: Batch studies), or accept "
            "that risk with --insecure-network")


def dask_security(address: str, tls_ca_file=None, tls_cert=None, tls_key=None,
                  insecure_network: bool = False):
    """How to connect to the Dask scheduler at ``address``; no connection is tried.

    Inputs: the ``--dask`` address (``tls://HOST:PORT``, ``tcp://HOST:PORT``, or
    ``HOST:PORT``, which Dask reads as its default scheme, tcp), the TLS files given as
    flags (paths to PEM files; None: not given) and ``--insecure-network``.

    Returns a ``distributed.security.Security`` for a ``tls://`` (or ``wss://``) address:
    the CA file, the client certificate and its key are the flags where given, else Dask's
    configuration (``distributed.comm.tls.ca-file``, ``distributed.comm.tls.client.cert``
    and ``.key``: a YAML file in ``~/.config/dask/`` or ``DASK_DISTRIBUTED__COMM__TLS__...``
    variables); encryption is required and the files are loaded here. Returns None for a
    plain address on the loopback interface (:func:`is_loopback`), or anywhere with
    ``insecure_network``.

    Raises ReachError (one line) for a plain address elsewhere without
    ``insecure_network`` (:func:`insecure_address_message`), TLS flags with a plain
    address, a TLS address without a CA or certificate, or TLS files that are missing or
    do not load; and when the distributed package is missing."""
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
        from distributed.security import Security
    except ImportError:
        raise ReachError("--dask needs the distributed package: pip install "
                         "'dask[distributed]'") from None
    try:
        scheme, loc = parse_address(address)
        host, _port = parse_host_port(loc, default_port=8786)
    except ValueError as exc:
        raise ReachError(f"--dask {address}: {exc}") from None
    given = {"--tls-ca-file": tls_ca_file, "--tls-cert": tls_cert, "--tls-key": tls_key}
    if scheme not in ENCRYPTED_SCHEMES:
        if any(given.values()):
            flags = ", ".join(k for k, v in given.items() if v)
            raise ReachError(f"{flags} given, but --dask {address} is a plain {scheme}:// "
                             "address: write it tls://HOST:PORT")
        if not (insecure_network or is_loopback(host)):
            raise ReachError(insecure_address_message(address))
        return None
    chosen = {k: v for k, v in (("tls_ca_file", tls_ca_file), ("tls_client_cert", tls_cert),
                                ("tls_client_key", tls_key)) if v}
    security = Security(require_encryption=True, **chosen)
    missing = [(flag, key) for flag, key, value in (
        ("--tls-ca-file", "distributed.comm.tls.ca-file", security.tls_ca_file),
        ("--tls-cert", "distributed.comm.tls.client.cert", security.tls_client_cert))
        if not value]
    if missing:
        raise ReachError(f"--dask {address} needs the cluster's CA and a certificate signed "
                         "by it, with its key: give "
                         + " and ".join(flag for flag, _ in missing) + " (and --tls-key), "
                         "or set " + " and ".join(key for _, key in missing)
                         + " (and .client.key) in Dask's configuration")
    for flag, value in (("--tls-ca-file", security.tls_ca_file),
                        ("--tls-cert", security.tls_client_cert),
                        ("--tls-key", security.tls_client_key)):
        if value and "\n" not in value and not Path(value).is_file():
            raise ReachError(f"{flag}: file '{value}' not found")
    try:
        security.get_connection_args("client")      # loads the CA, certificate and key
    except (OSError, ValueError) as exc:            # ssl.SSLError is an OSError
        raise ReachError(f"the TLS files do not load (CA '{security.tls_ca_file}', "
                         f"certificate '{security.tls_client_cert}', key "
                         f"'{security.tls_client_key}'): {exc}") from None
    return security


def connect(address: str, security):
    """A ``distributed.Client`` of the scheduler at ``address``, connected with
    ``security`` (:func:`dask_security`); a ReachError (one line) if it cannot connect or
    the TLS handshake fails."""
    from distributed import Client

    try:
        return Client(address, security=security, timeout=20)
    except OSError as exc:
        raise ReachError(_connect_error(address, exc)) from None


def run_on_cluster(client, specs):
    """Yield results of ``specs`` from the cluster of ``client`` as they finish. Stopped
    early (a signal, an error), the futures not yet done are cancelled."""
    from distributed import as_completed

    futures = []
    try:
        futures = client.map(dask_task, specs, key=[f"reach-{s['id']}" for s in specs],
                             pure=False)
        ids = {f.key: s["id"] for f, s in zip(futures, specs)}
        for fut in as_completed(futures):
            try:
                yield fut.result()
            except Exception as exc:
                yield {"id": ids[fut.key], "error": f"{type(exc).__name__}: {exc}"}
    finally:
        if any(not f.done() for f in futures):
            client.cancel(futures)


def _connect_error(address: str, exc: OSError) -> str:
    """One line for a failed connection to the scheduler: Dask's reason without its
    connection description, and for a refused TLS handshake what to check."""
    reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    reason = reason.rpartition(">: ")[2]
    if "SSL" in reason or "certificate" in reason:
        return (f"the Dask scheduler at {address} and this client did not accept each "
                f"other's TLS certificates ({reason}): --tls-cert must be signed by the CA "
                "the cluster trusts, and --tls-ca-file must be the CA that signed the "
                "scheduler's certificate")
    return f"cannot reach the Dask scheduler at {address}: {reason}"
