"""Certificates for a lab's cells: a certificate authority, and a key and certificate per name.

``flexhrc certs DIR`` writes what Zenoh's TLS with mutual authentication needs
(``docs/cell.md``, "Securing a cell"): the lab's CA, one key and certificate for the cell (the
manager) and one for each agent, and a Zenoh configuration file per name that uses them, ready
for ``--zenoh-config``. Only a process holding a certificate the CA signed can then connect to
the cell — or read from it.

Usage::

    from flexhrc.transport.certs import make_lab

    lab = make_lab("lab", names=["cell", "left", "right", "human"], days=365)
    lab.config("left")      # lab/left.json5: flexhrc agent robot ... --zenoh-config lab/left.json5

Files in ``DIR`` (each written atomically; private keys readable by their owner only, 0600):

* ``ca.pem``, ``ca.key``: the CA. When both exist already they are used again, so an agent
  added later (``flexhrc certs DIR --names cell,left,right,human,camera``) joins the same lab;
  a name whose certificate exists is kept as it is.
* ``NAME.pem``, ``NAME.key``: the certificate (common name ``NAME``, the names Zenoh's access
  control matches with ``cert_common_names``; valid for loopback and every address in
  ``hosts``) and its key.
* ``NAME.json5``: a Zenoh configuration with these files (absolute paths), ``enable_mtls``,
  multicast scouting off. The cell's (``cell``) listens on ``tls/HOST:PORT``; an agent's
  connects there and listens nowhere, so nothing else reaches it.

Needs the ``cryptography`` package (in the ``zenoh`` extra).
"""

from __future__ import annotations

import contextlib
import datetime as dt
import ipaddress
import json
import os
import re
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError, OptionalDependencyError

try:
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID
except ImportError as exc:  # pragma: no cover - exercised only without the extra
    raise OptionalDependencyError("flexhrc certs", "zenoh", "cryptography") from exc

__all__ = ["CELL", "DEFAULT_HOSTS", "DEFAULT_NAMES", "Lab", "access_control", "make_lab"]

#: The name of the cell's (the manager's) certificate.
CELL = "cell"
DEFAULT_NAMES = (CELL, "left", "right", "human")
#: Addresses every certificate is valid for (a server's name is checked when an agent connects).
DEFAULT_HOSTS = ("localhost", "127.0.0.1", "::1")
_NAME = re.compile(r"[A-Za-z0-9_\-]+")


@dataclass
class Lab:
    """What :func:`make_lab` wrote: the folder, the CA and each name's files."""

    dir: Path
    names: list[str]
    written: list[Path] = field(default_factory=list)
    kept: list[str] = field(default_factory=list)  # names whose certificate existed already

    @property
    def ca(self) -> Path:
        return self.dir / "ca.pem"

    def cert(self, name: str) -> Path:
        return self.dir / f"{name}.pem"

    def key(self, name: str) -> Path:
        return self.dir / f"{name}.key"

    def config(self, name: str) -> Path:
        return self.dir / f"{name}.json5"


def make_lab(
    directory: str | Path,
    *,
    names: Sequence[str] = DEFAULT_NAMES,
    days: int = 365,
    hosts: Iterable[str] = (),
    listen: str | None = None,
) -> Lab:
    """Write a CA and a key, certificate and Zenoh config for each of ``names`` into
    ``directory`` (created if needed; see the module docstring). ``days``: how long the
    certificates are valid; ``hosts``: the DNS names and IP addresses they are valid for
    besides :data:`DEFAULT_HOSTS` (loopback; the cell host's, for agents on other hosts);
    ``listen``: the cell's endpoint (default ``tls/127.0.0.1:7447``; the first non-loopback
    host of ``hosts`` makes ``tls/HOST:7447``), which the agents' configs connect to. Bad
    arguments raise one :class:`~flexhrc.errors.FlexhrcError` naming the option."""
    names = list(dict.fromkeys(names))
    if not names:
        raise FlexhrcError("--names: give at least one name (e.g. cell,left,right,human)")
    for name in names:
        if not _NAME.fullmatch(name) or name in ("ca",):
            raise FlexhrcError(
                f"--names {name!r}: letters, digits, '_' and '-' only (and not 'ca')"
            )
    if not isinstance(days, int) or isinstance(days, bool) or not 1 <= days <= 36500:
        raise FlexhrcError(f"--days must be a whole number of days in 1..36500, got {days!r}")
    hosts = list(dict.fromkeys(h.strip() for h in hosts if h.strip()))
    sans = [_san(h) for h in dict.fromkeys([*DEFAULT_HOSTS, *hosts])]
    if listen is None:
        outside = [h for h in hosts if not _loopback(h)]
        listen = f"tls/{_hostport(outside[0] if outside else '127.0.0.1', 7447)}"
    if not listen.startswith("tls/"):
        raise FlexhrcError(f"--listen {listen!r}: the cell's endpoint must be tls/HOST:PORT")
    root = Path(directory)
    if root.exists() and not root.is_dir():
        raise FlexhrcError(f"{root}: not a directory")
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise FlexhrcError(f"{root}: cannot create the folder: {exc.strerror or exc}") from None
    root = root.resolve()
    lab = Lab(root, names)
    now = dt.datetime.now(dt.UTC) - dt.timedelta(minutes=5)  # clocks differ a little
    ca_key, ca_cert = _ca(lab, now, days)
    for name in names:
        if lab.cert(name).exists() and lab.key(name).exists():
            lab.kept.append(name)
        else:
            key = ec.generate_private_key(ec.SECP256R1())
            cert = (
                _builder(name, ca_cert.subject, key, now, days)
                .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                .add_extension(_usage(ca=False), critical=True)
                .add_extension(
                    x509.ExtendedKeyUsage(
                        [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]
                    ),
                    critical=False,
                )
                .add_extension(x509.SubjectAlternativeName(sans), critical=False)
                .add_extension(
                    x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()),
                    critical=False,
                )
                .sign(ca_key, hashes.SHA256())
            )
            _write(lab.key(name), _key_pem(key), private=True, lab=lab)
            _write(lab.cert(name), cert.public_bytes(serialization.Encoding.PEM), lab=lab)
    # the cell's last: its access control names every agent of the lab, earlier ones too
    for name in sorted(set(names) | ({CELL} if lab.cert(CELL).exists() else set()),
                       key=lambda n: n == CELL):  # fmt: skip
        _write(lab.config(name), _config(lab, name, listen).encode(), lab=lab)
    return lab


def _ca(lab: Lab, now: dt.datetime, days: int) -> tuple[Any, Any]:
    """The lab's CA: the one in the folder, else a new one."""
    key_path, cert_path = lab.dir / "ca.key", lab.ca
    if key_path.exists() and cert_path.exists():
        try:
            key = serialization.load_pem_private_key(key_path.read_bytes(), password=None)
            cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
        except (ValueError, TypeError, OSError) as exc:
            raise FlexhrcError(f"{lab.dir}: the CA there cannot be read: {exc}") from None
        return key, cert
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"flexhrc lab CA {lab.dir.name}")])
    cert = (
        _builder(subject, subject, key, now, days)
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(_usage(ca=True), critical=True)
        .sign(key, hashes.SHA256())
    )
    _write(key_path, _key_pem(key), private=True, lab=lab)
    _write(cert_path, cert.public_bytes(serialization.Encoding.PEM), lab=lab)
    return key, cert


def _builder(
    subject: str | x509.Name, issuer: x509.Name, key: Any, now: dt.datetime, days: int
) -> x509.CertificateBuilder:
    if isinstance(subject, str):
        subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, subject)])
    return (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(issuer)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now)
        .not_valid_after(now + dt.timedelta(days=days))
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
    )


def _usage(*, ca: bool) -> x509.KeyUsage:
    """A CA signs certificates; an agent's key signs its TLS handshakes (ECDHE)."""
    return x509.KeyUsage(
        digital_signature=True,
        content_commitment=False,
        key_encipherment=False,
        data_encipherment=False,
        key_agreement=not ca,
        key_cert_sign=ca,
        crl_sign=ca,
        encipher_only=False,
        decipher_only=False,
    )


def _key_pem(key: Any) -> bytes:
    return bytes(
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
    )


def _san(host: str) -> x509.GeneralName:
    try:
        return x509.IPAddress(ipaddress.ip_address(host))
    except ValueError:
        if not re.fullmatch(r"[A-Za-z0-9.\-]+", host):
            raise FlexhrcError(f"--hosts {host!r}: not a host name or an IP address") from None
        return x509.DNSName(host)


def _loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _hostport(host: str, port: int) -> str:
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def _config(lab: Lab, name: str, listen: str) -> str:
    """The Zenoh configuration of ``name``: TLS with mutual authentication on its files; the
    cell listens on ``listen``, an agent connects to it and listens nowhere."""
    tls = {
        "root_ca_certificate": str(lab.ca),
        "enable_mtls": True,
        "listen_certificate": str(lab.cert(name)),
        "listen_private_key": str(lab.key(name)),
        "connect_certificate": str(lab.cert(name)),
        "connect_private_key": str(lab.key(name)),
    }
    cell = name == CELL
    config: dict[str, Any] = {
        "mode": "peer",
        "listen": {"endpoints": [listen] if cell else []},
        "connect": {"endpoints": [] if cell else [listen]},
        "scouting": {"multicast": {"enabled": False}},
        # only TLS links: a plain tcp/ endpoint given by mistake is refused by Zenoh itself
        "transport": {"link": {"protocols": ["tls"], "tls": tls}},
    }
    head = (
        f"// Zenoh configuration of {name!r} in the lab {lab.dir} (written by `flexhrc certs`).\n"
        f"// Use: flexhrc {'cell' if cell else 'agent'} ... --zenoh-config {lab.config(name)}\n"
        "// TLS with mutual authentication: only holders of a certificate of this lab's CA\n"
        '// connect. See docs/cell.md, "Securing a cell".\n'
    )
    if cell:
        agents = sorted(p.stem for p in lab.dir.glob("*.pem") if p.stem not in ("ca", CELL))
        config["access_control"] = access_control(agents)
        head += (
            "// access_control: each agent, known by its certificate's common name, may send\n"
            "// only the manager's inputs and declare only its own liveliness token.\n"
        )
    return head + json.dumps(config, indent=2) + "\n"


#: Every kind of message Zenoh's access control filters.
_ALL_MESSAGES = [
    "put", "delete", "declare_subscriber", "query", "reply", "declare_queryable",
    "liveliness_token", "liveliness_query", "declare_liveliness_subscriber",
]  # fmt: skip
#: What an agent sends the manager (``docs/protocol.md``): the rest (``cmd/``, ``suggest/``,
#: ``options/``, ``state``) only the manager publishes.
_AGENT_INPUTS = ("ack", "human", "intent", "percept", "join")


def access_control(agents: Sequence[str]) -> dict[str, Any]:
    """Zenoh's access control for the cell's session (``access_control`` of its config): every
    message goes out to the lab's agents; from an agent — matched by its certificate's common
    name — come only publications on the manager's inputs (:data:`_AGENT_INPUTS`), its own
    liveliness token ``alive/NAME``, and subscriptions (reading within the lab is allowed).
    So a certified ``left`` cannot send a ``stop`` on ``cmd/right``, an ``end`` on ``state`` or
    the token of ``right``. Anything else is denied (``default_permission``)."""
    rules: list[dict[str, Any]] = [
        {
            "id": "to_the_agents",
            "messages": _ALL_MESSAGES,
            "flows": ["egress"],
            "permission": "allow",
            "key_exprs": ["flexhrc/**"],
        },
        {
            "id": "agents_listen",
            "messages": [
                "declare_subscriber",
                "declare_liveliness_subscriber",
                "liveliness_query",
                "reply",
            ],
            "flows": ["ingress"],
            "permission": "allow",
            "key_exprs": ["flexhrc/**"],
        },
        {
            "id": "agents_send_inputs",
            "messages": ["put"],
            "flows": ["ingress"],
            "permission": "allow",
            "key_exprs": [f"flexhrc/*/{topic}" for topic in _AGENT_INPUTS],
        },
    ]
    policies: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    for agent in agents:
        rules.append(
            {
                "id": f"token_of_{agent}",
                "messages": ["liveliness_token"],
                "flows": ["ingress"],
                "permission": "allow",
                "key_exprs": [f"flexhrc/*/alive/{agent}"],
            }
        )
        subjects.append({"id": agent, "cert_common_names": [agent]})
        policies.append(
            {
                "id": f"agent_{agent}",
                "rules": [
                    "to_the_agents",
                    "agents_listen",
                    "agents_send_inputs",
                    f"token_of_{agent}",
                ],
                "subjects": [agent],
            }
        )
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }


def _write(path: Path, data: bytes, *, lab: Lab, private: bool = False) -> None:
    """Write ``data`` to ``path`` atomically (temporary file in the folder, then rename); a
    private key is created readable by its owner only (0600) and never is otherwise."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)  # created 0600
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        if not private:
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise FlexhrcError(f"{path}: cannot write: {exc.strerror or exc}") from None
    lab.written.append(path)
