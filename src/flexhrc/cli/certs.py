"""``flexhrc certs DIR``: a lab's CA, and a key, certificate and Zenoh config per cell and agent."""

from __future__ import annotations

import argparse

from flexhrc.cli.common import add_json_flag, emit, int_range


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "certs",
        help="write a lab's CA and a certificate and Zenoh config per cell and agent (TLS)",
        description="Write what Zenoh's TLS with mutual authentication needs to secure a cell "
        "(docs/cell.md, 'Securing a cell'): DIR/ca.pem and ca.key (kept when they exist, so "
        "names can be added later), and for each name NAME.pem, NAME.key (mode 0600) and "
        "NAME.json5, a Zenoh config for --zenoh-config. The name 'cell' is the manager's.",
    )
    p.add_argument("dir", metavar="DIR", help="folder to write into (created if needed)")
    p.add_argument(
        "--names",
        default="cell,left,right,human",
        metavar="A,B,...",
        help="comma-separated names: 'cell' (the manager) and the agents (default "
        "cell,left,right,human); a certificate's common name is its name",
    )
    p.add_argument(
        "--days",
        type=int_range(1, 36500),
        default=365,
        metavar="N",
        help="days the certificates are valid (default 365)",
    )
    p.add_argument(
        "--hosts",
        default="",
        metavar="H,...",
        help="host names and addresses the certificates are valid for besides loopback: the "
        "cell host's, for agents on other hosts (the first is where the cell's config listens)",
    )
    p.add_argument(
        "--listen",
        metavar="ENDPOINT",
        help="the cell's endpoint, in the configs (default tls/127.0.0.1:7447, or tls/HOST:7447 "
        "for the first non-loopback --hosts entry HOST)",
    )
    add_json_flag(p)
    p.set_defaults(func=cmd_certs)


def cmd_certs(args: argparse.Namespace) -> int:
    from flexhrc.transport.certs import make_lab

    lab = make_lab(
        args.dir,
        names=[n.strip() for n in args.names.split(",") if n.strip()],
        days=args.days,
        hosts=args.hosts.split(","),
        listen=args.listen,
    )
    data = {
        "dir": str(lab.dir),
        "ca": str(lab.ca),
        "names": {
            n: {"cert": str(lab.cert(n)), "key": str(lab.key(n)), "config": str(lab.config(n))}
            for n in lab.names
        },
        "kept": lab.kept,
    }

    def text() -> str:
        lines = [f"CA {lab.ca}"]
        for n in lab.names:
            kept = " (certificate kept)" if n in lab.kept else ""
            lines.append(f"{n}: {lab.cert(n).name}, {lab.key(n).name}, {lab.config(n)}{kept}")
        lines.append(
            f"use: flexhrc cell ... --zenoh-config {lab.config('cell')}; "
            f"flexhrc agent ... --zenoh-config {lab.dir}/NAME.json5"
        )
        return "\n".join(lines)

    emit(args, data, text)
    return 0
